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
        overlap=ALLOW_OVERLAP,
        # SPLIT=PATH items, each quoted already: the shell command uses them unquoted
        distances=lambda wc, input: name_pairs(conf.eval_splits, input.distances),
        attributes=lambda wc, input: name_pairs(conf.eval_splits, input.attributes),
        tolerance=lambda wc: PLAN.datasets[wc.dataset].tolerance,
        radius=lambda wc: f"--radius {r}" if (r := PLAN.datasets[wc.dataset].radius) is not None else "",
        # method §13: a dataset's ground-truth file (its input above), cut to each split by the stage
        ground_truth=lambda wc: ground_truth_option(PLAN, wc.dataset),
        matcher=MATCHER,
        baselines=BASELINES,
        modes=" ".join(conf.modes),
    shell:
        "vpr-smr baselines --dataset {wildcards.dataset:q} --method {wildcards.method:q}"
        " --seq-len {wildcards.seq_len} --tolerance {params.tolerance} {params.radius} {params.ground_truth}"
        " {params.matcher} --distances {params.distances} --attributes {params.attributes}"
        " --predictors {input.predictors:q} {params.baselines} --modes {params.modes}"
        " --out {output:q} {params.overlap} > {log:q} 2>&1"


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
        overlap=ALLOW_OVERLAP,
        # SPLIT=PATH items, each quoted already: the shell command uses them unquoted
        distances=lambda wc, input: name_pairs(conf.eval_splits, input.distances),
        attributes=lambda wc, input: name_pairs(conf.eval_splits, input.attributes),
        tolerance=lambda wc: PLAN.datasets[wc.dataset].tolerance,
        radius=lambda wc: f"--radius {r}" if (r := PLAN.datasets[wc.dataset].radius) is not None else "",
        # method §13: a dataset's ground-truth file (its input below), cut to each split by the stage
        ground_truth=lambda wc: ground_truth_option(PLAN, wc.dataset),
        matcher=MATCHER,
        baselines=BASELINES,
        modes=" ".join(conf.modes),
        sweep=lambda wc: "--sweep" if "protocol_sweep" in EXPERIMENTS and wc.dataset in SWEEP_DATASETS else "",
    shell:
        "vpr-smr metrics --dataset {wildcards.dataset:q} --method {wildcards.method:q}"
        " --seq-len {wildcards.seq_len} --tolerance {params.tolerance} {params.radius} {params.ground_truth}"
        " {params.matcher} --distances {params.distances}"
        " --attributes {params.attributes} --predictor {input.predictor:q} {params.baselines} --modes {params.modes}"
        " {params.sweep}"
        " --out {output:q} {params.overlap} > {log:q} 2>&1"


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
        overlap=ALLOW_OVERLAP,
        # SPLIT=PATH items, each quoted already: the shell command uses them unquoted
        distances=lambda wc, input: name_pairs(conf.eval_splits, input.distances),
        attributes=lambda wc, input: name_pairs(conf.eval_splits, input.attributes),
        tolerance=lambda wc: PLAN.datasets[wc.dataset].tolerance,
        radius=lambda wc: f"--radius {r}" if (r := PLAN.datasets[wc.dataset].radius) is not None else "",
        # method §13: a dataset's ground-truth file (its input below), cut to each split by the stage
        ground_truth=lambda wc: ground_truth_option(PLAN, wc.dataset),
        matcher=MATCHER,
        baselines=BASELINES,
    shell:
        "vpr-smr queries --seq-len {wildcards.seq_len} --tolerance {params.tolerance} {params.radius} {params.ground_truth}"
        " {params.matcher} --distances {params.distances} --attributes {params.attributes} --predictor {input.predictor:q}"
        " {params.baselines} --out {output:q} {params.overlap} > {log:q} 2>&1"
