# The predictor: trained on the pooled train split of every method, and scored per method.
rule train:
    input:
        train=split_attributes(OUT, METHODS, conf.train_split),
        # every evaluation split (the configuration's names and order), each with every method's attributes
        evaluate=evaluation_attributes(OUT, METHODS, conf.eval_splits),
    output:
        models=predictor_paths(OUT, "{dataset}", "{seq_len}", conf.seeds),
        report=predictor_report_path(predictor_path(OUT, "{dataset}", "{seq_len}")),
    log:
        log_path(OUT, predictor_path(OUT, "{dataset}", "{seq_len}")),
    params:
        layout=RESULTS_LAYOUT,  # its files' layout: a run of an earlier one trains again, and scores again below
        # the stage's job record (method §7): the predictor's settings, the validation split, the seeds, every
        # evaluation split by its name with every method's attributes of it
        job=lambda wc, input, output: job_text(TrainJob(
            wc.dataset, int(wc.seq_len), tuple(input.train), split_files(conf.eval_splits, input.evaluate),
            training(conf), conf.seeds, output.models[0])),
    shell:
        shell_command(TRAIN)


rule evaluate:
    input:
        attributes=lambda wc: [attributes_path(OUT, wc.dataset, wc.method, wc.seq_len, split)
                             for split in conf.eval_splits],
        predictors=predictor_paths(OUT, "{dataset}", "{seq_len}", conf.seeds),
    output:
        evaluation=evaluation_path(OUT, "{dataset}", "{method}", "{seq_len}"),
        timing=timing_path(evaluation_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    log:
        log_path(OUT, evaluation_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        # the stage's job record (method §§7-9): each evaluation split's attributes by its name, the seeds'
        # predictors, the modes, and the trust levels and restoration where the configuration's experiments ask them
        job=lambda wc, input, output: job_text(EvaluateJob(
            wc.dataset, wc.method, int(wc.seq_len), dict(zip(conf.eval_splits, input.attributes, strict=True)),
            tuple(input.predictors), tuple(conf.modes),
            tuple(conf.trust_levels) if "trust" in EXPERIMENTS else (), "restoration" in EXPERIMENTS,
            conf.allow_split_overlap, output.evaluation)),
    shell:
        shell_command(EVALUATE)
