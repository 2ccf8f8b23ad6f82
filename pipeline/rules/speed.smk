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
        # the stage's job record: the profile, the velocity search set, the dataset's tolerance, every method's train
        # and table split in the configuration's order (the pooled training order), the predictor's settings
        job=lambda wc, input, output: job_text(SpeedJob(
            wc.dataset, int(wc.seq_len), wc.profile, tuple(conf.speed.velocities), PLAN.datasets[wc.dataset].tolerance,
            dict(zip(METHODS, input.train, strict=True)), dict(zip(METHODS, input.table, strict=True)),
            PredictorParams.of(conf.predictor.to_json()), conf.allow_split_overlap, output[0])),
        layout=RESULTS_LAYOUT,  # its file's layout: a run of an earlier one computes it again
    # One BLAS thread per job: OpenBLAS's default (a thread per core) makes two jobs side by side on 2 cores fight
    # over them, measured 3 to 7 times slower than one thread each; the numbers are the same (checked on the demo).
    threads: 1
    shell:
        "OMP_NUM_THREADS={threads} " + shell_command(studies.SPEED)
