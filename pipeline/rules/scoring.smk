# The training-free scorers against the predictor (method §12), at every predictor seed's budget: every L, so that
# the sequence-length ablation shows the best of them beside the predictor.
rule baselines:
    input:
        distances=lambda wc: [distances_path(OUT, wc.dataset, wc.method, split) for split in conf.eval_splits],
        attributes=lambda wc: [attributes_path(OUT, wc.dataset, wc.method, wc.seq_len, split)
                             for split in conf.eval_splits],
        predictors=predictor_paths(OUT, "{dataset}", "{seq_len}", conf.seeds),
        truth=lambda wc: ground_truth_input(PLAN, wc.dataset),
    output:
        baselines_path(OUT, "{dataset}", "{method}", "{seq_len}"),
    log:
        log_path(OUT, baselines_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        # the stage's job record: the splits' files by name, the dataset's ground truth (method §§11, 13: a file is
        # its input above, cut to each split by the stage), the run's matcher and the scorers' settings (method §12)
        job=lambda wc, input, output: job_text(BaselinesJob(
            wc.dataset, wc.method, int(wc.seq_len), dict(zip(conf.eval_splits, input.distances, strict=True)),
            dict(zip(conf.eval_splits, input.attributes, strict=True)), tuple(input.predictors),
            PLAN.datasets[wc.dataset].truth, conf.sequence_matching, scorers=conf.baselines, modes=tuple(conf.modes),
            allow_split_overlap=conf.allow_split_overlap, out=output[0])),
    shell:
        shell_command(BASELINES)


rule vpr_metrics:
    input:
        distances=lambda wc: [distances_path(OUT, wc.dataset, wc.method, split) for split in conf.eval_splits],
        attributes=lambda wc: [attributes_path(OUT, wc.dataset, wc.method, wc.seq_len, split)
                             for split in conf.eval_splits],
        predictor=predictor_path(OUT, "{dataset}", "{seq_len}"),  # seed 0 (the authors' recipe)
        truth=lambda wc: ground_truth_input(PLAN, wc.dataset),
    output:
        vpr_metrics_path(OUT, "{dataset}", "{method}", "{seq_len}"),
    log:
        log_path(OUT, vpr_metrics_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        # the stage's job record: SPLIT=PATH items, the dataset's ground truth (method §§11, 13: a file is its input
        # above, cut to each split by the stage), the run's matcher, the scorers' settings (method §12), the modes, and
        # the protocol sweep where the experiment runs on a dataset with a tolerance or a radius
        job=lambda wc, input, output: job_text(MetricsJob(
            tuple(f"{split}={path}" for split, path in zip(conf.eval_splits, input.distances, strict=True)),
            int(wc.seq_len), PLAN.datasets[wc.dataset].truth, conf.sequence_matching, predictor=input.predictor,
            attributes=dict(zip(conf.eval_splits, input.attributes, strict=True)), modes=tuple(conf.modes),
            sweep="protocol_sweep" in EXPERIMENTS and wc.dataset in SWEEP_DATASETS, dataset=wc.dataset,
            method=wc.method, scorers=conf.baselines, allow_split_overlap=conf.allow_split_overlap, out=output[0])),
    shell:
        shell_command(METRICS)


# The per-query table of the same scoring, its own job: it does not depend on the metric modes, so a change of them
# reruns the metrics and the report, not this table and the match inspector that reads it.
rule queries:
    input:
        distances=lambda wc: [distances_path(OUT, wc.dataset, wc.method, split) for split in conf.eval_splits],
        attributes=lambda wc: [attributes_path(OUT, wc.dataset, wc.method, wc.seq_len, split)
                             for split in conf.eval_splits],
        predictor=predictor_path(OUT, "{dataset}", "{seq_len}"),  # seed 0 (the authors' recipe)
        truth=lambda wc: ground_truth_input(PLAN, wc.dataset),
    output:
        queries_path(OUT, "{dataset}", "{method}", "{seq_len}"),
    log:
        log_path(OUT, queries_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        # the stage's job record: as the metrics' above, without the modes and the sweep
        job=lambda wc, input, output: job_text(QueriesJob(
            tuple(f"{split}={path}" for split, path in zip(conf.eval_splits, input.distances, strict=True)),
            int(wc.seq_len), PLAN.datasets[wc.dataset].truth, conf.sequence_matching, predictor=input.predictor,
            attributes=dict(zip(conf.eval_splits, input.attributes, strict=True)), scorers=conf.baselines,
            allow_split_overlap=conf.allow_split_overlap, out=output[0])),
    shell:
        shell_command(QUERIES)
