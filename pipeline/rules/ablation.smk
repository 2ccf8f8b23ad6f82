# The paper's ablations (at the Table I sequence length).

rule attribute_ablation:
    input:
        train=split_attributes(OUT, METHODS, conf.train_split),
        # the validation split (the first of eval_splits), then the last of them: Table II's two
        evaluate=evaluation_attributes(OUT, METHODS, TABLE2_SPLITS),
    output:
        attribute_ablation_path(OUT, "{dataset}", "{seq_len}"),
    log:
        log_path(OUT, attribute_ablation_path(OUT, "{dataset}", "{seq_len}")),
    params:
        layout=RESULTS_LAYOUT,  # its file's layout: a run of an earlier one computes it again
        # the stage's job record: the predictor's settings, Table II's splits by name with every method's attributes
        job=lambda wc, input, output: job_text(AttributeAblationJob(
            wc.dataset, int(wc.seq_len), training(conf).predictor, tuple(input.train),
            split_files(TABLE2_SPLITS, input.evaluate), conf.allow_split_overlap, output[0])),
    shell:
        shell_command(ABLATION_ATTRIBUTES)


rule predictor_without:
    # The held-out method's files are not inputs: a change to them does not retrain this predictor.
    input:
        train=lambda wc: other_attributes(OUT, METHODS, wc, conf.train_split),
        # the validation split's, scored by this predictor's report (none without a validation split)
        validation=lambda wc: other_attributes(OUT, METHODS, wc, VALIDATION) if VALIDATION else [],
    output:
        without_predictor_path(OUT, "{dataset}", "{seq_len}", "{method}"),
    log:
        log_path(OUT, without_predictor_path(OUT, "{dataset}", "{seq_len}", "{method}")),
    params:
        layout=RESULTS_LAYOUT,  # its file's layout, as the pooled predictor's
        # the stage's job record: the other methods' train files by method, the validation split's METHOD=PATH
        # items, the predictor's settings (its validation split: the first evaluation split given, the only one)
        job=lambda wc, input, output: job_text(WithoutJob(
            wc.dataset, int(wc.seq_len), wc.method,
            dict(zip([m for m in METHODS if m != wc.method], input.train, strict=True)),
            split_files([VALIDATION] if VALIDATION else [], method_items(METHODS, wc.method, input.validation)),
            training(conf, validation=False), output[0])),
    shell:
        shell_command(ABLATION_WITHOUT)


rule held_out:
    input:
        attributes=attributes_path(OUT, "{dataset}", "{method}", "{seq_len}", conf.table_split),
        pooled=predictor_path(OUT, "{dataset}", "{seq_len}"),
        without=without_predictor_path(OUT, "{dataset}", "{seq_len}", "{method}"),
    output:
        held_out_path(OUT, "{dataset}", "{seq_len}", "{method}"),
    log:
        log_path(OUT, held_out_path(OUT, "{dataset}", "{seq_len}", "{method}")),
    params:
        # the stage's job record: the held-out method's table split under the pooled and the without predictor
        job=lambda wc, input, output: job_text(HeldOutJob(
            wc.dataset, wc.method, int(wc.seq_len), input.attributes, input.pooled, input.without, tuple(conf.modes),
            conf.allow_split_overlap, output[0])),
    shell:
        shell_command(ABLATION_HELD_OUT)
