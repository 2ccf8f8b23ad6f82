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
        "vpr-smr distances --descriptors {input} --split {wildcards.split} --frames {params.frames}"
        " --out {output} > {log} 2>&1"


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
        "vpr-smr attributes --distances {input} --seq-len {wildcards.seq_len} --tolerance {params.tolerance}"
        " --out {output} > {log} 2>&1"


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
        predictor=canonical(conf["predictor"]),
        seeds=conf["seeds"],
    shell:
        "vpr-smr train --dataset {wildcards.dataset} --seq-len {wildcards.seq_len} --predictor {params.predictor:q}"
        " --seeds {params.seeds} --train {input.train} --val {input.val} --test {input.test}"
        " --out {output.models[0]} > {log} 2>&1"


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
        features=lambda wc, input: " ".join(
            f"{split}={path}" for split, path in zip(conf["eval_splits"], input.features)
        ),
        modes=" ".join(conf["modes"]),
        trust_levels=" ".join(str(level) for level in conf["trust_levels"]) if "trust" in EXPERIMENTS else "",
        restoration="" if "restoration" in EXPERIMENTS else "--no-restoration",
    shell:
        "vpr-smr evaluate --dataset {wildcards.dataset} --method {wildcards.method} --seq-len {wildcards.seq_len}"
        " --features {params.features} --predictors {input.predictors} --modes {params.modes}"
        " --trust-levels {params.trust_levels} {params.restoration} --out {output.evaluation} > {log} 2>&1"
