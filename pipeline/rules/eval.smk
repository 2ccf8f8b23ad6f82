rule distances:
    input:
        f"{OUT}/descriptors/{{dataset}}/{{method}}.h5",
    output:
        f"{OUT}/distances/{{dataset}}/{{method}}/{{split}}.h5",
    log:
        f"{OUT}/logs/distances/{{dataset}}/{{method}}/{{split}}.log",
    shell:
        "{CLI} distances --config {CONFIG_FILE} --dataset {wildcards.dataset} --split {wildcards.split}"
        " --descriptors {input} --out {output} > {log} 2>&1"


rule attributes:
    input:
        f"{OUT}/distances/{{dataset}}/{{method}}/{{split}}.h5",
    output:
        f"{OUT}/features/{{dataset}}/{{method}}/L{{seq_len}}/{{split}}.h5",
    log:
        f"{OUT}/logs/features/{{dataset}}/{{method}}/L{{seq_len}}/{{split}}.log",
    params:
        tolerance=lambda wc: conf["datasets"][wc.dataset].get("tolerance", 2),
    shell:
        "{CLI} attributes --distances {input} --seq-len {wildcards.seq_len} --tolerance {params.tolerance}"
        " --out {output} > {log} 2>&1"


def features_of(split):
    return lambda wc: expand(
        f"{OUT}/features/{wc.dataset}/{{method}}/L{wc.seq_len}/{split}.h5", method=METHODS
    )


rule train:
    input:
        train=features_of(conf["train_split"]),
        val=features_of("val") if "val" in conf["eval_splits"] else [],
        test=features_of("test") if "test" in conf["eval_splits"] else [],
    output:
        model=f"{OUT}/predictors/{{dataset}}/L{{seq_len}}.h5",
        report=f"{OUT}/predictors/{{dataset}}/L{{seq_len}}.json",
    log:
        f"{OUT}/logs/predictors/{{dataset}}/L{{seq_len}}.log",
    shell:
        "{CLI} train --config {CONFIG_FILE} --dataset {wildcards.dataset} --seq-len {wildcards.seq_len}"
        " --train {input.train} --val {input.val} --test {input.test} --out {output.model} > {log} 2>&1"


rule evaluate:
    input:
        features=lambda wc: [
            f"{OUT}/features/{wc.dataset}/{wc.method}/L{wc.seq_len}/{split}.h5" for split in conf["eval_splits"]
        ],
        predictor=f"{OUT}/predictors/{{dataset}}/L{{seq_len}}.h5",
    output:
        f"{OUT}/evaluation/{{dataset}}/{{method}}/L{{seq_len}}.json",
    log:
        f"{OUT}/logs/evaluation/{{dataset}}/{{method}}/L{{seq_len}}.log",
    params:
        features=lambda wc, input: " ".join(
            f"{split}={path}" for split, path in zip(conf["eval_splits"], input.features)
        ),
    shell:
        "{CLI} evaluate --config {CONFIG_FILE} --dataset {wildcards.dataset} --method {wildcards.method}"
        " --seq-len {wildcards.seq_len} --features {params.features} --predictor {input.predictor}"
        " --out {output} > {log} 2>&1"


rule tables:
    input:
        evaluations=expand(f"{OUT}/evaluation/{{dataset}}/{{method}}/L{{seq_len}}.json",
                           dataset=DATASETS, method=METHODS, seq_len=SEQ_LENS),
        predictors=expand(f"{OUT}/predictors/{{dataset}}/L{{seq_len}}.json", dataset=DATASETS, seq_len=SEQ_LENS),
    output:
        f"{OUT}/tables/table1.csv",
        f"{OUT}/tables/table1.md",
        f"{OUT}/tables/table1.tex",
        f"{OUT}/tables/predictor.csv",
    log:
        f"{OUT}/logs/tables.log",
    params:
        split=conf["table_split"],
    shell:
        "{CLI} tables --evaluations {input.evaluations} --predictors {input.predictors} --split {params.split}"
        " --out {OUT} > {log} 2>&1"
