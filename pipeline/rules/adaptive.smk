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
        overlap=ALLOW_OVERLAP,
        # SPLIT=PATH items, each quoted already: the shell command uses them unquoted
        attributes=lambda wc, input: " ".join([name_pairs([conf.table_split] * len(input.table), input.table),
                                               name_pairs([VALIDATION] * len(input.validation), input.validation)]),
        # each length's seed-0 file: the command reads the other seeds beside it
        predictors=lambda wc, input: " ".join(shlex.quote(path) for path in input.predictors[:: conf.seeds]),
        seeds=conf.seeds,
        split=conf.table_split,
        validation=VALIDATION_OPTION,
        baselines=BASELINES,
        modes=" ".join(conf.modes),
        layout=RESULTS_LAYOUT,  # its file's layout: a run of an earlier one computes it again
    shell:
        "vpr-smr adaptive --dataset {wildcards.dataset:q} --method {wildcards.method:q}"
        " --matcher-tag {wildcards.tag:q} --attributes {params.attributes} --predictors {params.predictors}"
        " --seeds {params.seeds} --split {params.split:q} {params.validation} --distances {input.distances:q}"
        " {params.baselines} --modes {params.modes} --out {output.result:q} {params.overlap} > {log:q} 2>&1"
