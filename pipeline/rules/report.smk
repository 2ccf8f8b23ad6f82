# The report that gathers every result of the run.
rule report:
    input:
        # the files of the experiments installed packages register (pipeline.experiment), which the report reads
        experiments=PLUGIN_FILES,
        evaluations=expand(evaluation_path(OUT, "{dataset}", "{method}", "{seq_len}"),
                           dataset=DATASETS, method=METHODS, seq_len=SEQ_LENS),
        # the training-free baselines (method §12), every L: their table, figures and the sequence-length ablation
        baselines=expand(baselines_path(OUT, "{dataset}", "{method}", "{seq_len}"),
                         dataset=DATASETS, method=METHODS, seq_len=SEQ_LENS),
        # matched to their evaluations by the report, by dataset, method and L
        timings=expand(timing_path(evaluation_path(OUT, "{dataset}", "{method}", "{seq_len}")),
                       dataset=DATASETS, method=METHODS, seq_len=SEQ_LENS),
        predictors=expand(predictor_report_path(predictor_path(OUT, "{dataset}", "{seq_len}")),
                          dataset=DATASETS, seq_len=SEQ_LENS),
        attribute_ablations=expand(attribute_ablation_path(OUT, "{dataset}", TABLE_L), dataset=DATASETS)
        if "attributes" in EXPERIMENTS else [],
        leave_one_out=expand(held_out_path(OUT, "{dataset}", TABLE_L, "{method}"),
                             dataset=DATASETS, method=METHODS) if "leave_one_method_out" in EXPERIMENTS else [],
        # the speed experiment's profiles (none when it is off), in the configuration's order
        speed=expand(speed_path(OUT, "{dataset}", TABLE_L, "{profile}"), dataset=SPEED_DATASETS,
                     profile=SPEED_PROFILES),
        # the standard VPR metrics and the match inspector's figures, at the table's L
        metrics=expand(vpr_metrics_path(OUT, "{dataset}", "{method}", TABLE_L), dataset=DATASETS, method=METHODS),
        match_figures=expand(match_figure_path(OUT, "{dataset}", "{method}", TABLE_L),
                             dataset=DATASETS, method=METHODS),
        matrix_figures=expand(matrix_figure_path(OUT, "{dataset}", "{method}", TABLE_L),
                              dataset=DATASETS, method=METHODS),
        # the experiment matchers (method §14), at the table's L
        matchers=expand(matchers_path(OUT, "{dataset}", "{method}", TABLE_L), dataset=DATASETS, method=METHODS)
        if "matchers" in EXPERIMENTS else [],
        # the experiment adaptive_seq_len (method §15): every length, each matcher's tag; the live timings beside
        adaptive=expand(adaptive_path(OUT, "{dataset}", "{tag}", "{method}"), dataset=DATASETS, tag=ADAPTIVE_TAGS,
                        method=METHODS) if "adaptive_seq_len" in EXPERIMENTS else [],
        # the experiment deployment (method §16), at the table's L
        deployment=expand(deployment_path(OUT, "{dataset}", "{method}", TABLE_L), dataset=DATASETS, method=METHODS)
        if "deployment" in EXPERIMENTS else [],
        # read for their provenance (checkpoint and frame-list hashes) only
        descriptors=expand(descriptors_path(OUT, "{dataset}", "{method}"), dataset=DATASETS, method=METHODS),
    output:
        [f"{OUT}/{name}" for name in report_outputs(conf, EXPERIMENTS, SPEED_DATASETS, SWEEP_DATASETS)],
    log:
        report_log_path(OUT),
    params:
        # the stage's job record: every file above (the rule's own input: it has no wildcards, so its one job's
        # files are the rule's); the configuration's split names (the tables' columns and headings name them),
        # Table I's L; what the report shows as the run's configuration (every setting that changes a number) and
        # the dataset cards, in the configuration's order of datasets and splits
        job=lambda wc: job_text(ReportJob(
            report_files(rules.report.input), conf.table_split, tuple(conf.eval_splits),
            conf.train_split, (int(TABLE_L),), "seq_len" in EXPERIMENTS,
            JsonObject(json.loads(report_settings(conf.to_json()))), JsonObject(json.loads(report_datasets(PLAN))),
            OUT)),
    shell:
        shell_command(reporting.REPORT)
