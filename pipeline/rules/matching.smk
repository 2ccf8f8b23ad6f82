# From descriptors to attributes: the distance matrix of a split, and its queries' attributes.
rule distances:
    input:
        descriptors_path(OUT, "{dataset}", "{method}"),
    output:
        distances_path(OUT, "{dataset}", "{method}", "{split}"),
    log:
        log_path(OUT, distances_path(OUT, "{dataset}", "{method}", "{split}")),
    params:
        # the stage's job record: the split's frames (method §11: its reference range, only where it differs from
        # its query range) and the method's `distance` (or its backend's default)
        job=lambda wc, input, output: job_text(DistancesJob(
            input[0], wc.split, PLAN.datasets[wc.dataset].splits[wc.split],
            PLAN.datasets[wc.dataset].reference_splits.get(wc.split), PLAN.metrics[wc.method], out=output[0])),
    shell:
        shell_command(DISTANCES)

rule attributes:
    input:
        distances=distances_path(OUT, "{dataset}", "{method}", "{split}"),
        truth=lambda wc: ground_truth_input(PLAN, wc.dataset),
    output:
        attributes_path(OUT, "{dataset}", "{method}", "{seq_len}", "{split}"),
    log:
        log_path(OUT, attributes_path(OUT, "{dataset}", "{method}", "{seq_len}", "{split}")),
    params:
        # the stage's job record (method §§5, 11, 13): the matcher, the dataset's ground truth, and the candidates the
        # training-free scorers need (method §12: only a change of their number recomputes these)
        job=lambda wc, input, output: job_text(AttributesJob(
            input.distances, int(wc.seq_len), PLAN.datasets[wc.dataset].truth, conf.sequence_matching,
            candidates=conf.baselines.candidates, out=output[0])),
    shell:
        shell_command(ATTRIBUTES)
