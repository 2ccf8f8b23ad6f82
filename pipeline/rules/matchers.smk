# The experiment `matchers` (method §14): each compared matcher with its own attributes and its own predictor (the
# authors' recipe, every seed) at Table I's sequence length, then one job per dataset and method scoring them all on
# the queries every matcher evaluates (per method: the jobs of a dataset's methods run side by side). The run's own matcher (sequence_matching) reuses the run's files; every other
# one gets its attributes and predictors under matchers/<dataset>/<tag>/ from the same stages as the run's.


use rule attributes as matcher_attributes with:
    output:
        matcher_attributes_path(OUT, "{dataset}", "{tag}", "{method}", "{seq_len}", "{split}"),
    log:
        log_path(OUT, matcher_attributes_path(OUT, "{dataset}", "{tag}", "{method}", "{seq_len}", "{split}")),
    wildcard_constraints:
        tag="|".join(map(re.escape, MATCHER_TAGS)) or "(?!)",  # no other matcher: the rule matches nothing
    params:
        matcher=lambda wc: matcher_flags(COMPARED[wc.tag]),


use rule train as matcher_train with:
    input:
        train=lambda wc: [matcher_attributes_path(OUT, wc.dataset, wc.tag, method, wc.seq_len, conf.train_split)
                          for method in METHODS],
        evaluate=lambda wc: [matcher_attributes_path(OUT, wc.dataset, wc.tag, method, wc.seq_len, split)
                             for split in conf.eval_splits for method in METHODS],
    output:
        models=matcher_predictor_paths(OUT, "{dataset}", "{tag}", "{seq_len}", conf.seeds),
        report=predictor_report_path(matcher_predictor_path(OUT, "{dataset}", "{tag}", "{seq_len}")),
    log:
        log_path(OUT, matcher_predictor_path(OUT, "{dataset}", "{tag}", "{seq_len}")),
    wildcard_constraints:
        tag="|".join(map(re.escape, MATCHER_TAGS)) or "(?!)",


rule matchers:
    input:
        files=lambda wc: experiment_files(experiment_inputs(OUT, conf, wc.dataset, wc.method, wc.seq_len)),
        # the table split: the ground truth's reference positions (the scorer spread)
        distances=distances_path(OUT, "{dataset}", "{method}", conf.table_split),
        truth=lambda wc: ground_truth_input(PLAN, wc.dataset),
    output:
        matchers_path(OUT, "{dataset}", "{method}", "{seq_len}"),
    log:
        log_path(OUT, matchers_path(OUT, "{dataset}", "{method}", "{seq_len}")),
    params:
        overlap=ALLOW_OVERLAP,
        inputs=lambda wc: json.dumps(experiment_inputs(OUT, conf, wc.dataset, wc.method, wc.seq_len),
                                     separators=(",", ":")),
        # METHOD=PATH, quoted already: the shell command uses it unquoted
        distances=lambda wc, input: name_pairs([wc.method], [input.distances]),
        split=conf.table_split,
        validation=VALIDATION_OPTION,
        tolerance=lambda wc: PLAN.datasets[wc.dataset].tolerance,
        radius=lambda wc: f"--radius {r}" if (r := PLAN.datasets[wc.dataset].radius) is not None else "",
        ground_truth=lambda wc: ground_truth_option(PLAN, wc.dataset),
        baselines=BASELINES,
        modes=" ".join(conf.modes),
        layout=RESULTS_LAYOUT,  # its file's layout: a run of an earlier one computes it again
    shell:
        "vpr-smr compare-matchers --dataset {wildcards.dataset:q} --method {wildcards.method:q}"
        " --seq-len {wildcards.seq_len}"
        " --inputs {params.inputs:q} --distances {params.distances} --split {params.split:q} {params.validation}"
        " --tolerance {params.tolerance} {params.radius} {params.ground_truth} {params.baselines}"
        " --modes {params.modes} --out {output:q} {params.overlap} > {log:q} 2>&1"
