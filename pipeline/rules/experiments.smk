# The experiments installed packages register (pipeline.experiment): a rule per job of each one the configuration
# turns on, calling its stage with its job record (`vpr-smr COMMAND --job JSON`); the report waits for their files
# (the Snakefile adds them to its input).
for _experiment in PLUGIN_EXPERIMENTS:
    for _job in _experiment.jobs:

        rule:
            name:
                _experiment.rule_name(_job)
            input:
                unpack(lambda wc, job=_job: dict(job.inputs(OUT, conf, PLAN, dict(wc.items())))),
            output:
                f"{OUT}/{_job.output}",
            log:
                log_path(OUT, f"{OUT}/{_job.output}"),
            params:
                job=lambda wc, input, output, job=_job: job_text(job.record(conf, PLAN, dict(wc.items()),
                                                                            dict(input.items()), output[0])),
            shell:
                shell_command(_job.stage)
