# The experiment adaptive_seq_len (method §15): per dataset, matcher and method, the sequence length chosen per query
# by each length's predictor (or uniqueness) against every fixed length, with the live matcher's time. A matcher of
# the experiment matchers other than the run's own reads the attributes and predictors that experiment's rules
# compute under matchers/<dataset>/<tag>/, here at every L of seq_lens.


rule adaptive:
    input:
        table=lambda wc: adaptive_files(OUT, conf, ADAPTIVE[wc.tag], wc.tag, wc.dataset, wc.method, conf.table_split),
        validation=lambda wc: adaptive_files(OUT, conf, ADAPTIVE[wc.tag], wc.tag, wc.dataset, wc.method, VALIDATION)
        if VALIDATION else [],
        predictors=lambda wc: adaptive_predictors(OUT, conf, ADAPTIVE[wc.tag], wc.tag, wc.dataset),
        # the table split's matrix, fed frame by frame to the live matcher (its time per query)
        distances=distances_path(OUT, "{dataset}", "{method}", conf.table_split),
    output:
        result=adaptive_path(OUT, "{dataset}", "{tag}", "{method}"),
        timing=timing_path(adaptive_path(OUT, "{dataset}", "{tag}", "{method}")),
    log:
        log_path(OUT, adaptive_path(OUT, "{dataset}", "{tag}", "{method}")),
    wildcard_constraints:
        tag="|".join(map(re.escape, ADAPTIVE_TAGS)) or "(?!)",  # the experiment off: the rule matches nothing
    params:
        # the stage's job record: per split every length's attributes, each length's seed-0 predictor (the command
        # reads the other seeds beside it), the table split's matrix (the live timing), the scorers' settings
        job=lambda wc, input, output: job_text(AdaptiveJob(
            length_files([(conf.table_split, input.table), (VALIDATION, input.validation)]),
            tuple(input.predictors[:: conf.seeds]), conf.seeds, conf.table_split, VALIDATION, input.distances,
            wc.dataset, wc.method, wc.tag, conf.baselines, tuple(conf.modes), conf.allow_split_overlap,
            output.result)),
        layout=RESULTS_LAYOUT,  # its file's layout: a run of an earlier one computes it again
    shell:
        shell_command(studies.ADAPTIVE)
