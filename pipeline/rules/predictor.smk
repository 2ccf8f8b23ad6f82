# The predictor: trained on the pooled train split of every method, and scored per method.
rule train:
    input:
        # the train split's attributes of every method (the configuration's order), then every evaluation split's
        # (its names and order), each with every method's
        unpack(FILES.train),
    output:
        models=predictor_paths(OUT, "{dataset}", "{seq_len}", conf.seeds),
        report=predictor_report_path(predictor_path(OUT, "{dataset}", "{seq_len}")),
    log:
        log_path(OUT, predictor_path(OUT, "{dataset}", "{seq_len}")),
    params:
        layout=RESULTS_LAYOUT,  # its files' layout: a run of an earlier one trains again, and scores again below
        # the stage's job record (method §7): the predictor's settings, the validation split, the seeds, every
        # evaluation split by its name with every method's attributes of it
        job=job_param(FILES.train, lambda wc, files: TrainJob(
            wc.dataset, int(wc.seq_len), tuple(files.train), split_files(conf.eval_splits, files.evaluate),
            training(conf), conf.seeds, predictor_paths(OUT, wc.dataset, wc.seq_len, conf.seeds)[0])),
    shell:
        shell_command(TRAIN)


rule evaluate:
    input:
        unpack(FILES.evaluate),  # the method's attributes of every evaluation split, every seed's predictor
    output:
        evaluation=evaluation_path(OUT, "{dataset}", "{method}", "{seq_len}"),
        timing=timing_path(evaluation_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    log:
        log_path(OUT, evaluation_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        # the stage's job record (method §§7-9): each evaluation split's attributes by its name, the seeds'
        # predictors, the modes, and the trust levels and restoration where the configuration's experiments ask them
        job=job_param(FILES.evaluate, lambda wc, files: EvaluateJob(
            wc.dataset, wc.method, int(wc.seq_len), dict(zip(conf.eval_splits, files.attributes, strict=True)),
            tuple(files.predictors), tuple(conf.modes),
            tuple(conf.trust_levels) if "trust_levels" in EXPERIMENTS else (), "restoration" in EXPERIMENTS,
            conf.allow_split_overlap, evaluation_path(OUT, wc.dataset, wc.method, wc.seq_len))),
    shell:
        shell_command(EVALUATE)
