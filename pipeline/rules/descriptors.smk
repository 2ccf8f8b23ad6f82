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
        # the stage's job record: the frames' settings and fingerprint; the method's settings without `distance`
        # (it changes the distance matrices, not the descriptors)
        job=lambda wc: job_text(DescriptorsJob(
            wc.dataset, wc.method, dataset_settings=canonical(PLAN.datasets[wc.dataset].frames_settings),
            method_settings=canonical(descriptor_settings(conf.methods[wc.method].to_json())),
            frames_sha256=PLAN.datasets[wc.dataset].frames_sha256, out=descriptors_path(OUT, wc.dataset, wc.method))),
        # what the backend's code computes: a new revision computes the descriptors again
        revision=lambda wc: descriptor_revision(conf.methods[wc.method].backend),
    threads: 2
    resources:
        gpu=1,
        # Batch size and decoding workers change how fast a job runs, not what it computes: a resource, not a
        # param, so that changing them reruns nothing (the stage's speed settings, given beside its job)
        extraction=extraction_options(conf),
    shell:
        shell_command(DESCRIPTORS, "--threads {threads} {resources.extraction}")
