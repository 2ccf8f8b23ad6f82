rule descriptors:
    input:
        checkpoint=lambda wc: [PLAN.checkpoints[wc.method]] if PLAN.checkpoints[wc.method] else [],
        lists=lambda wc: list(PLAN.datasets[wc.dataset].list_files),
        positions=lambda wc: list(PLAN.datasets[wc.dataset].positions_files),  # method §11: the positions CSVs
    output:
        descriptors_path(OUT, "{dataset}", "{method}"),
    log:
        log_path(OUT, descriptors_path(OUT, "{dataset}", "{method}")),
    params:
        dataset=lambda wc: canonical(PLAN.datasets[wc.dataset].frames_settings),
        frames_sha256=lambda wc: PLAN.datasets[wc.dataset].frames_sha256,
        # without `distance`: it changes the distance matrices, not the descriptors
        method=lambda wc: canonical(descriptor_settings(conf.methods[wc.method].to_json())),
        # what the backend's code computes: a new revision computes the descriptors again
        revision=lambda wc: descriptor_revision(conf.methods[wc.method].backend),
    threads: 2
    resources:
        gpu=1,
        # Batch size and decoding workers change how fast a job runs, not what it computes: a resource, not a
        # param, so that changing them reruns nothing.
        extraction=extraction_options(conf),
    # Every name and path is quoted (`:q`): an output or dataset folder may hold spaces, quotes or `;`.
    shell:
        "vpr-smr descriptors --dataset {wildcards.dataset:q} --dataset-settings {params.dataset:q}"
        " --frames-sha256 {params.frames_sha256} --method {wildcards.method:q} --method-settings {params.method:q}"
        " --threads {threads} {resources.extraction} --out {output:q} > {log:q} 2>&1"
