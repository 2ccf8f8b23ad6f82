rule tables:
    input:
        evaluations=expand(f"{OUT}/evaluation/{{dataset}}/{{method}}/L{{seq_len}}.json",
                           dataset=DATASETS, method=METHODS, seq_len=SEQ_LENS),
        predictors=expand(f"{OUT}/predictors/{{dataset}}/L{{seq_len}}.json", dataset=DATASETS, seq_len=SEQ_LENS),
    output:
        table1=multiext(f"{OUT}/tables/table1", ".csv", ".md", ".tex"),
        predictor=f"{OUT}/tables/predictor.csv",
        figures=table_figures(conf),
    log:
        f"{OUT}/logs/tables.log",
    params:
        split=conf["table_split"],
        out=lambda wc, output: os.path.dirname(os.path.dirname(output.predictor)),  # the run folder
    shell:
        "vpr-smr tables --evaluations {input.evaluations} --predictors {input.predictors} --split {params.split}"
        " --out {params.out} > {log} 2>&1"
