# The match inspector: thumbnails of a fixed sample of the table split's queries with their matches, and the split's
# distance matrix with the sequence matches the predictor keeps or removes (the report shows both).


rule inspect:
    input:
        queries=queries_path(OUT, "{dataset}", "{method}", "{seq_len}"),
        distances=distances_path(OUT, "{dataset}", "{method}", conf.table_split),
        truth=lambda wc: ground_truth_input(PLAN, wc.dataset),
    output:
        matches=match_figure_path(OUT, "{dataset}", "{method}", "{seq_len}"),
        matrix=matrix_figure_path(OUT, "{dataset}", "{method}", "{seq_len}"),
    log:
        log_path(OUT, match_figure_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        # the images are read for the thumbnails: the frames' settings and fingerprint, as the descriptors job's
        dataset=lambda wc: canonical(PLAN.datasets[wc.dataset].frames_settings),
        frames_sha256=lambda wc: PLAN.datasets[wc.dataset].frames_sha256,
        frames=lambda wc: "{} {}".format(*PLAN.datasets[wc.dataset].splits[conf.table_split]),
        tolerance=lambda wc: PLAN.datasets[wc.dataset].tolerance,
        radius=lambda wc: f"--radius {r}" if (r := PLAN.datasets[wc.dataset].radius) is not None else "",
        # method §13: a dataset's ground-truth file (its input below), cut to each split by the stage
        ground_truth=lambda wc: ground_truth_option(PLAN, wc.dataset),
        matcher=MATCHER,
        split=conf.table_split,
    shell:
        "vpr-smr inspect --queries {input.queries:q} --distances {input.distances:q}"
        " --dataset {wildcards.dataset:q} --dataset-settings {params.dataset:q}"
        " --frames-sha256 {params.frames_sha256} --seq-len {wildcards.seq_len} --split {params.split:q}"
        " --frames {params.frames} --tolerance {params.tolerance} {params.radius} {params.ground_truth} {params.matcher}"
        " --match-figure {output.matches:q} --matrix-figure {output.matrix:q} > {log:q} 2>&1"
