rule distances:
    input:
        descriptors_path(OUT, "{dataset}", "{method}"),
    output:
        distances_path(OUT, "{dataset}", "{method}", "{split}"),
    log:
        log_path(OUT, distances_path(OUT, "{dataset}", "{method}", "{split}")),
    params:
        frames=lambda wc: "{} {}".format(*PLAN.datasets[wc.dataset].splits[wc.split]),
        # method §11: a split's reference range, only where it differs from its (query) range
        reference_frames=lambda wc: "--reference-frames {} {}".format(*PLAN.datasets[wc.dataset].reference_splits[
            wc.split]) if wc.split in PLAN.datasets[wc.dataset].reference_splits else "",
        metric=lambda wc: PLAN.metrics[wc.method],  # the method's `distance`, or its backend's default
    shell:
        "vpr-smr distances --descriptors {input:q} --split {wildcards.split:q} --frames {params.frames}"
        " {params.reference_frames} --metric {params.metric} --out {output:q} > {log:q} 2>&1"


rule attributes:
    input:
        distances=distances_path(OUT, "{dataset}", "{method}", "{split}"),
        truth=lambda wc: ground_truth_input(PLAN, wc.dataset),
    output:
        attributes_path(OUT, "{dataset}", "{method}", "{seq_len}", "{split}"),
    log:
        log_path(OUT, attributes_path(OUT, "{dataset}", "{method}", "{seq_len}", "{split}")),
    params:
        # the stage's job record (method §§5, 11, 13): the matcher, the dataset's ground truth, and the candidates the
        # training-free scorers need (method §12: only a change of their number recomputes these)
        job=lambda wc, input, output: job_text(AttributesJob(
            input.distances, int(wc.seq_len), PLAN.datasets[wc.dataset].truth, conf.sequence_matching,
            candidates=conf.baselines.candidates, out=output[0])),
    shell:
        shell_command(ATTRIBUTES)


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
        overlap=ALLOW_OVERLAP,
        predictor=canonical(conf.predictor.to_json()),
        seeds=conf.seeds,
        layout=RESULTS_LAYOUT,  # its files' layout: a run of an earlier one trains again, and scores again below
        # --evaluate SPLIT PATH... per evaluation split, each word quoted already: the shell command uses them unquoted
        evaluate=lambda wc, input: split_option("--evaluate", conf.eval_splits, input.evaluate),
        validation=VALIDATION_OPTION,
    shell:
        "vpr-smr train --dataset {wildcards.dataset:q} --seq-len {wildcards.seq_len}"
        " --predictor {params.predictor:q} --seeds {params.seeds} --train {input.train:q} {params.evaluate}"
        " {params.validation} --out {output.models[0]:q} {params.overlap} > {log:q} 2>&1"


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
        overlap=ALLOW_OVERLAP,
        # SPLIT=PATH items, each quoted already: the shell command uses them unquoted
        attributes=lambda wc, input: name_pairs(conf.eval_splits, input.attributes),
        modes=" ".join(conf.modes),
        trust_levels=" ".join(str(level) for level in conf.trust_levels) if "trust" in EXPERIMENTS else "",
        restoration="" if "restoration" in EXPERIMENTS else "--no-restoration",
    shell:
        "vpr-smr evaluate --dataset {wildcards.dataset:q} --method {wildcards.method:q}"
        " --seq-len {wildcards.seq_len} --attributes {params.attributes} --predictors {input.predictors:q}"
        " --modes {params.modes} --trust-levels {params.trust_levels} {params.restoration}"
        " --out {output.evaluation:q} {params.overlap} > {log:q} 2>&1"


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
