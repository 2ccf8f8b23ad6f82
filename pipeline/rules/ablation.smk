# The paper's ablations (at the Table I sequence length).

rule attribute_ablation:
    input:
        # every method's train split; the validation split (the first of eval_splits), then the last of them:
        # Table II's two
        unpack(FILES.attribute_ablation),
    output:
        attribute_ablation_path(OUT, "{dataset}", "{seq_len}"),
    log:
        log_path(OUT, attribute_ablation_path(OUT, "{dataset}", "{seq_len}")),
    params:
        layout=RESULTS_LAYOUT,  # its file's layout: a run of an earlier one computes it again
        # the stage's job record: the predictor's settings, Table II's splits by name with every method's attributes
        job=job_param(FILES.attribute_ablation, lambda wc, files: AttributeAblationJob(
            wc.dataset, int(wc.seq_len), training(conf).predictor, tuple(files.train),
            split_files(TABLE2_SPLITS, files.evaluate), conf.allow_split_overlap,
            attribute_ablation_path(OUT, wc.dataset, wc.seq_len))),
    shell:
        shell_command(ABLATION_ATTRIBUTES)


rule predictor_without:
    # The held-out method's files are not inputs: a change to them does not retrain this predictor.
    input:
        # the other methods' train split, and their validation split, scored by this predictor's report (none
        # without a validation split)
        unpack(FILES.predictor_without),
    output:
        without_predictor_path(OUT, "{dataset}", "{seq_len}", "{method}"),
    log:
        log_path(OUT, without_predictor_path(OUT, "{dataset}", "{seq_len}", "{method}")),
    params:
        layout=RESULTS_LAYOUT,  # its file's layout, as the pooled predictor's
        # the stage's job record: the other methods' train files by method, the validation split's METHOD=PATH
        # items, the predictor's settings (its validation split: the first evaluation split given, the only one)
        job=job_param(FILES.predictor_without, lambda wc, files: WithoutJob(
            wc.dataset, int(wc.seq_len), wc.method,
            dict(zip([m for m in METHODS if m != wc.method], files.train, strict=True)),
            split_files([VALIDATION] if VALIDATION else [], method_items(METHODS, wc.method, files.validation)),
            training(conf, validation=False), without_predictor_path(OUT, wc.dataset, wc.seq_len, wc.method))),
    shell:
        shell_command(ABLATION_WITHOUT)


rule held_out:
    input:
        unpack(FILES.held_out),  # the method's table split, the pooled predictor, the one trained without it
    output:
        held_out_path(OUT, "{dataset}", "{seq_len}", "{method}"),
    log:
        log_path(OUT, held_out_path(OUT, "{dataset}", "{seq_len}", "{method}")),
    params:
        # the stage's job record: the held-out method's table split under the pooled and the without predictor
        job=job_param(FILES.held_out, lambda wc, files: HeldOutJob(
            wc.dataset, wc.method, int(wc.seq_len), files.attributes, files.pooled, files.without, tuple(conf.modes),
            conf.allow_split_overlap, held_out_path(OUT, wc.dataset, wc.seq_len, wc.method))),
    shell:
        shell_command(ABLATION_HELD_OUT)
