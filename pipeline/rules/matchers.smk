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
        # the attributes stage's job with the compared matcher instead of the run's (sequence_matching)
        job=lambda wc, input, output: job_text(AttributesJob(
            input.distances, int(wc.seq_len), PLAN.datasets[wc.dataset].truth, COMPARED[wc.tag],
            candidates=conf.baselines.candidates, out=output[0])),


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
        # the stage's job record: the compared matchers' files, the table split's distances (the ground truth's
        # reference positions), the dataset's ground truth (method §§11, 13), the scorers' settings, the modes
        job=lambda wc, input, output: job_text(MatchersJob(
            wc.dataset, wc.method, int(wc.seq_len), ComparedInputs.from_setting(
                experiment_inputs(OUT, conf, wc.dataset, wc.method, wc.seq_len), "inputs"),
            {wc.method: input.distances}, conf.table_split, VALIDATION, PLAN.datasets[wc.dataset].truth,
            conf.baselines, tuple(conf.modes), conf.allow_split_overlap, output[0])),
        layout=RESULTS_LAYOUT,  # its file's layout: a run of an earlier one computes it again
    shell:
        shell_command(studies.COMPARE_MATCHERS)
