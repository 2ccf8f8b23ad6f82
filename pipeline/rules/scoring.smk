# The training-free scorers against the predictor (method §12), at every predictor seed's budget: every L, so that
# the sequence-length ablation shows the best of them beside the predictor.
rule baselines:
    input:
        # the method's distances and attributes of every evaluation split, every seed's predictor, the dataset's
        # ground-truth file (method §13; or none)
        unpack(FILES.baselines),
    output:
        baselines_path(OUT, "{dataset}", "{method}", "{seq_len}"),
    log:
        log_path(OUT, baselines_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        # the stage's job record: the splits' files by name, the dataset's ground truth (method §§11, 13: a file is
        # its input above, cut to each split by the stage), the run's matcher and the scorers' settings (method §12)
        job=job_param(FILES.baselines, lambda wc, files: BaselinesJob(
            wc.dataset, wc.method, int(wc.seq_len), dict(zip(conf.eval_splits, files.distances, strict=True)),
            dict(zip(conf.eval_splits, files.attributes, strict=True)), tuple(files.predictors),
            PLAN.datasets[wc.dataset].truth, conf.sequence_matching, scorers=conf.baselines, modes=tuple(conf.modes),
            allow_split_overlap=conf.allow_split_overlap, out=baselines_path(OUT, wc.dataset, wc.method, wc.seq_len))),
    shell:
        shell_command(BASELINES)


rule vpr_metrics:
    input:
        unpack(FILES.metrics),  # as the baselines', with the seed-0 predictor only (the authors' recipe)
    output:
        vpr_metrics_path(OUT, "{dataset}", "{method}", "{seq_len}"),
    log:
        log_path(OUT, vpr_metrics_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        # the stage's job record: SPLIT=PATH items, the dataset's ground truth (method §§11, 13: a file is its input
        # above, cut to each split by the stage), the run's matcher, the scorers' settings (method §12), the modes, and
        # the protocol sweep where the experiment runs on a dataset with a tolerance or a radius
        job=job_param(FILES.metrics, lambda wc, files: MetricsJob(
            tuple(f"{split}={path}" for split, path in zip(conf.eval_splits, files.distances, strict=True)),
            int(wc.seq_len), PLAN.datasets[wc.dataset].truth, conf.sequence_matching, predictor=files.predictor,
            attributes=dict(zip(conf.eval_splits, files.attributes, strict=True)), modes=tuple(conf.modes),
            sweep="protocol_sweep" in EXPERIMENTS and wc.dataset in SWEEP_DATASETS, dataset=wc.dataset,
            method=wc.method, scorers=conf.baselines, allow_split_overlap=conf.allow_split_overlap,
            out=vpr_metrics_path(OUT, wc.dataset, wc.method, wc.seq_len))),
    shell:
        shell_command(METRICS)


# The per-query table of the same scoring, its own job: it does not depend on the metric modes, so a change of them
# reruns the metrics and the report, not this table and the match inspector that reads it.
rule queries:
    input:
        unpack(FILES.metrics),  # as the baselines', with the seed-0 predictor only (the authors' recipe)
    output:
        queries_path(OUT, "{dataset}", "{method}", "{seq_len}"),
    log:
        log_path(OUT, queries_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        # the stage's job record: as the metrics' above, without the modes and the sweep
        job=job_param(FILES.metrics, lambda wc, files: QueriesJob(
            tuple(f"{split}={path}" for split, path in zip(conf.eval_splits, files.distances, strict=True)),
            int(wc.seq_len), PLAN.datasets[wc.dataset].truth, conf.sequence_matching, predictor=files.predictor,
            attributes=dict(zip(conf.eval_splits, files.attributes, strict=True)), scorers=conf.baselines,
            allow_split_overlap=conf.allow_split_overlap, out=queries_path(OUT, wc.dataset, wc.method, wc.seq_len))),
    shell:
        shell_command(QUERIES)
