# From descriptors to attributes: the distance matrix of a split, and its queries' attributes.
rule distances:
    input:
        unpack(FILES.distances),
    output:
        distances_path(OUT, "{dataset}", "{method}", "{split}"),
    log:
        log_path(OUT, distances_path(OUT, "{dataset}", "{method}", "{split}")),
    params:
        # the stage's job record: the split's frames (method §11: its reference range, only where it differs from
        # its query range) and the method's `distance` (or its backend's default)
        job=job_param(FILES.distances, lambda wc, files: DistancesJob(
            files.descriptors, wc.split, PLAN.datasets[wc.dataset].splits[wc.split],
            PLAN.datasets[wc.dataset].reference_splits.get(wc.split), PLAN.metrics[wc.method],
            out=distances_path(OUT, wc.dataset, wc.method, wc.split))),
    shell:
        shell_command(DISTANCES)

rule attributes:
    input:
        unpack(FILES.attributes),  # the split's distances, the dataset's ground-truth file (method §13; or none)
    output:
        attributes_path(OUT, "{dataset}", "{method}", "{seq_len}", "{split}"),
    log:
        log_path(OUT, attributes_path(OUT, "{dataset}", "{method}", "{seq_len}", "{split}")),
    params:
        # the stage's job record (method §§5, 11, 13): the matcher, the dataset's ground truth, and the candidates the
        # training-free scorers need (method §12: only a change of their number recomputes these)
        job=job_param(FILES.attributes, lambda wc, files: AttributesJob(
            files.distances, int(wc.seq_len), PLAN.datasets[wc.dataset].truth, conf.sequence_matching,
            candidates=conf.baselines.candidates,
            out=attributes_path(OUT, wc.dataset, wc.method, wc.seq_len, wc.split))),
    shell:
        shell_command(ATTRIBUTES)
