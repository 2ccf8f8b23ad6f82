# The match inspector: thumbnails of a fixed sample of the table split's queries with their matches, and the split's
# distance matrix with the sequence matches the predictor keeps or removes (the report shows both).


rule inspect:
    input:
        unpack(FILES.inspect),  # the per-query table, the table split's distances, the ground-truth file (or none)
    output:
        matches=match_figure_path(OUT, "{dataset}", "{method}", "{seq_len}"),
        matrix=matrix_figure_path(OUT, "{dataset}", "{method}", "{seq_len}"),
    log:
        log_path(OUT, match_figure_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        # the stage's job record: the images are read for the thumbnails (the frames' settings and fingerprint, as
        # the descriptors job's); the table split's frames; the dataset's ground truth (method §13: a file is cut to
        # the split by the stage) and the run's matcher, as its queries CSV was made
        job=job_param(FILES.inspect, lambda wc, files: InspectJob(
            files.queries, files.distances, match_figure_path(OUT, wc.dataset, wc.method, wc.seq_len),
            matrix_figure_path(OUT, wc.dataset, wc.method, wc.seq_len), wc.dataset,
            canonical(PLAN.datasets[wc.dataset].frames_settings), PLAN.datasets[wc.dataset].frames_sha256,
            int(wc.seq_len), conf.table_split, PLAN.datasets[wc.dataset].truth, conf.sequence_matching,
            frames=PLAN.datasets[wc.dataset].splits[conf.table_split])),
    shell:
        shell_command(INSPECT)
