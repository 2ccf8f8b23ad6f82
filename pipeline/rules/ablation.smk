# The paper's ablations (at the Table I sequence length).

rule attribute_ablation:
    input:
        train=split_attributes(OUT, METHODS, conf.train_split),
        # the validation split (the first of eval_splits), then the last of them: Table II's two
        evaluate=evaluation_attributes(OUT, METHODS, TABLE2_SPLITS),
    output:
        attribute_ablation_path(OUT, "{dataset}", "{seq_len}"),
    log:
        log_path(OUT, attribute_ablation_path(OUT, "{dataset}", "{seq_len}")),
    params:
        overlap=ALLOW_OVERLAP,
        layout=RESULTS_LAYOUT,  # its file's layout: a run of an earlier one computes it again
        predictor=canonical(conf.predictor.to_json()),
        # --evaluate SPLIT PATH... per split, each word quoted already: the shell command uses them unquoted
        evaluate=lambda wc, input: split_option("--evaluate", TABLE2_SPLITS, input.evaluate),
    shell:
        "vpr-smr ablation attributes --dataset {wildcards.dataset:q} --seq-len {wildcards.seq_len}"
        " --predictor {params.predictor:q} --train {input.train:q} {params.evaluate}"
        " --out {output:q} {params.overlap} > {log:q} 2>&1"


rule predictor_without:
    # The held-out method's files are not inputs: a change to them does not retrain this predictor.
    input:
        train=lambda wc: other_attributes(OUT, METHODS, wc, conf.train_split),
        # the validation split's, scored by this predictor's report (none without a validation split)
        validation=lambda wc: other_attributes(OUT, METHODS, wc, VALIDATION) if VALIDATION else [],
    output:
        without_predictor_path(OUT, "{dataset}", "{seq_len}", "{method}"),
    log:
        log_path(OUT, without_predictor_path(OUT, "{dataset}", "{seq_len}", "{method}")),
    params:
        overlap=ALLOW_OVERLAP,
        predictor=canonical(conf.predictor.to_json()),
        # METHOD=PATH items, each quoted already: the shell command uses them unquoted
        train=lambda wc, input: method_pairs(METHODS, wc.method, input.train),
        evaluate=lambda wc, input: split_option("--evaluate", [VALIDATION] if VALIDATION else [],
                                                method_items(METHODS, wc.method, input.validation)),
        layout=RESULTS_LAYOUT,  # its file's layout, as the pooled predictor's
    shell:
        "vpr-smr ablation without --dataset {wildcards.dataset:q} --seq-len {wildcards.seq_len}"
        " --method {wildcards.method:q} --predictor {params.predictor:q} --train {params.train}"
        " {params.evaluate} --out {output:q} {params.overlap} > {log:q} 2>&1"


rule held_out:
    input:
        attributes=attributes_path(OUT, "{dataset}", "{method}", "{seq_len}", conf.table_split),
        pooled=predictor_path(OUT, "{dataset}", "{seq_len}"),
        without=without_predictor_path(OUT, "{dataset}", "{seq_len}", "{method}"),
    output:
        held_out_path(OUT, "{dataset}", "{seq_len}", "{method}"),
    log:
        log_path(OUT, held_out_path(OUT, "{dataset}", "{seq_len}", "{method}")),
    params:
        overlap=ALLOW_OVERLAP,
        modes=" ".join(conf.modes),
    shell:
        "vpr-smr ablation held-out --dataset {wildcards.dataset:q} --method {wildcards.method:q}"
        " --seq-len {wildcards.seq_len} --attributes {input.attributes:q} --pooled {input.pooled:q}"
        " --without {input.without:q} --modes {params.modes} --out {output:q} {params.overlap} > {log:q} 2>&1"
