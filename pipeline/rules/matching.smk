# From descriptors to attributes: the distance matrix of a split, and its queries' attributes.
rule distances:
    input:
        descriptors_path(OUT, "{dataset}", "{method}"),
    output:
        distances_path(OUT, "{dataset}", "{method}", "{split}"),
    log:
        log_path(OUT, distances_path(OUT, "{dataset}", "{method}", "{split}")),
    params:
        frames=lambda wc: "{} {}".format(*PLAN.datasets[wc.dataset].splits[wc.split]),
        # method §11: a split's reference range, only where it differs from its (query) range
        reference_frames=lambda wc: "--reference-frames {} {}".format(*PLAN.datasets[wc.dataset].reference_splits[
            wc.split]) if wc.split in PLAN.datasets[wc.dataset].reference_splits else "",
        metric=lambda wc: PLAN.metrics[wc.method],  # the method's `distance`, or its backend's default
    shell:
        "vpr-smr distances --descriptors {input:q} --split {wildcards.split:q} --frames {params.frames}"
        " {params.reference_frames} --metric {params.metric} --out {output:q} > {log:q} 2>&1"


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
