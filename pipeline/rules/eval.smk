rule distances:
    input:
        f"{OUT}/descriptors/{{dataset}}/{{method}}.h5",
    output:
        f"{OUT}/distances/{{dataset}}/{{method}}/{{split}}.h5",
    log:
        f"{OUT}/logs/distances/{{dataset}}/{{method}}/{{split}}.log",
    params:
        frames=lambda wc: "{} {}".format(*PLAN.datasets[wc.dataset].splits[wc.split]),
    shell:
        "vpr-smr distances --descriptors {input:q} --split {wildcards.split:q} --frames {params.frames}"
        " --out {output:q} > {log:q} 2>&1"


rule attributes:
    input:
        f"{OUT}/distances/{{dataset}}/{{method}}/{{split}}.h5",
    output:
        f"{OUT}/features/{{dataset}}/{{method}}/L{{seq_len}}/{{split}}.h5",
    log:
        f"{OUT}/logs/features/{{dataset}}/{{method}}/L{{seq_len}}/{{split}}.log",
    params:
        tolerance=lambda wc: PLAN.datasets[wc.dataset].tolerance,
    shell:
        "vpr-smr attributes --distances {input:q} --seq-len {wildcards.seq_len} --tolerance {params.tolerance}"
        " --out {output:q} > {log:q} 2>&1"


rule train:
    input:
        train=split_features(OUT, METHODS, conf["train_split"]),
        val=split_features(OUT, METHODS, "val") if "val" in conf["eval_splits"] else [],
        test=split_features(OUT, METHODS, "test") if "test" in conf["eval_splits"] else [],
    output:
        models=seed_models(conf, f"{OUT}/predictors/{{dataset}}/L{{seq_len}}"),
        report=f"{OUT}/predictors/{{dataset}}/L{{seq_len}}.json",
    log:
        f"{OUT}/logs/predictors/{{dataset}}/L{{seq_len}}.log",
    params:
        overlap=ALLOW_OVERLAP,
        predictor=canonical(conf["predictor"]),
        seeds=conf["seeds"],
    shell:
        "vpr-smr train --dataset {wildcards.dataset:q} --seq-len {wildcards.seq_len}"
        " --predictor {params.predictor:q} --seeds {params.seeds} --train {input.train:q} --val {input.val:q}"
        " --test {input.test:q} --out {output.models[0]:q} {params.overlap} > {log:q} 2>&1"


rule evaluate:
    input:
        features=lambda wc: [features_path(OUT, wc.dataset, wc.method, wc.seq_len, split) for split in conf["eval_splits"]],
        predictors=seed_models(conf, f"{OUT}/predictors/{{dataset}}/L{{seq_len}}"),
    output:
        evaluation=f"{OUT}/evaluation/{{dataset}}/{{method}}/L{{seq_len}}.json",
        timing=f"{OUT}/evaluation/{{dataset}}/{{method}}/L{{seq_len}}.timing.json",
    log:
        f"{OUT}/logs/evaluation/{{dataset}}/{{method}}/L{{seq_len}}.log",
    params:
        overlap=ALLOW_OVERLAP,
        # SPLIT=PATH items, each quoted already: the shell command uses them unquoted
        features=lambda wc, input: name_pairs(conf["eval_splits"], input.features),
        modes=" ".join(conf["modes"]),
        trust_levels=" ".join(str(level) for level in conf["trust_levels"]) if "trust" in EXPERIMENTS else "",
        restoration="" if "restoration" in EXPERIMENTS else "--no-restoration",
    shell:
        "vpr-smr evaluate --dataset {wildcards.dataset:q} --method {wildcards.method:q}"
        " --seq-len {wildcards.seq_len} --features {params.features} --predictors {input.predictors:q}"
        " --modes {params.modes} --trust-levels {params.trust_levels} {params.restoration}"
        " --out {output.evaluation:q} {params.overlap} > {log:q} 2>&1"
