# The speed experiment (method §11): each dataset's train and table splits re-driven at simulated speeds, the fixed
# matcher against velocity search, at Table I's sequence length. One job per dataset and profile, so that the
# profiles run side by side; each reads the distance matrices only (the simulated queries are their columns).


rule speed:
    input:
        # every method, in the configuration's order: the pooled training order (method §7)
        train=lambda wc: [distances_path(OUT, wc.dataset, method, conf.train_split) for method in METHODS],
        table=lambda wc: [distances_path(OUT, wc.dataset, method, conf.table_split) for method in METHODS],
    output:
        speed_path(OUT, "{dataset}", "{seq_len}", "{profile}"),
    log:
        log_path(OUT, speed_path(OUT, "{dataset}", "{seq_len}", "{profile}")),
    wildcard_constraints:
        profile="|".join(map(re.escape, SPEED_PROFILES)) or "(?!)",  # no profile: the rule matches nothing
    params:
        overlap=ALLOW_OVERLAP,
        predictor=canonical(conf.predictor.to_json()),
        tolerance=lambda wc: PLAN.datasets[wc.dataset].tolerance,
        velocities=" ".join(str(float(v)) for v in conf.speed.velocities),  # 1 and 1.0 alike
        # METHOD=PATH items, each quoted already: the shell command uses them unquoted
        train=lambda wc, input: name_pairs(METHODS, input.train),
        table=lambda wc, input: name_pairs(METHODS, input.table),
        layout=RESULTS_LAYOUT,  # its file's layout: a run of an earlier one computes it again
    # One BLAS thread per job: OpenBLAS's default (a thread per core) makes two jobs side by side on 2 cores fight
    # over them, measured 3 to 7 times slower than one thread each; the numbers are the same (checked on the demo).
    threads: 1
    shell:
        "OMP_NUM_THREADS={threads} vpr-smr speed --dataset {wildcards.dataset:q} --seq-len {wildcards.seq_len}"
        " --profile {wildcards.profile:q} --velocities {params.velocities} --tolerance {params.tolerance}"
        " --train {params.train} --table {params.table} --predictor {params.predictor:q} --out {output:q}"
        " {params.overlap} > {log:q} 2>&1"
