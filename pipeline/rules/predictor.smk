# The predictor: trained on the pooled train split of every method, and scored per method.
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
