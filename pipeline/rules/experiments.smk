# The experiments, the tool's own (pipeline/experiments/) and those installed packages register (pipeline.experiment),
# that the configuration turns on: a rule per job of each, calling its stage with its job record (`vpr-smr COMMAND
# --job JSON`); the report waits for their files. The record is computed from the wildcards alone (Job.job_record:
# the job's inputs and output from its declaration), so that Snakemake compares it with the last run's: a param
# made from a rule's input or output is left out of that check.
from vpr_smr.pipeline.experiment import running

for _experiment in running(EXPERIMENTS):
    for _job in _experiment.jobs:

        rule:
            name:
                _experiment.rule_name(_job)
            input:
                unpack(lambda wc, job=_job: dict(job.inputs(OUT, conf, PLAN, dict(wc.items())))),
            output:
                *(f"{OUT}/{pattern}" for pattern in _job.patterns),
            log:
                log_path(OUT, f"{OUT}/{_job.output}"),
            wildcard_constraints:
                **_job.constraints(conf, PLAN),
            threads: _job.threads or 1
            params:
                job=lambda wc, job=_job: job_text(job.job_record(OUT, conf, PLAN, dict(wc.items()))),
                # its file's layout: a run of an earlier one computes it again
                **({"layout": RESULTS_LAYOUT} if _job.layout else {}),
            shell:
                _job.shell_prefix + shell_command(_job.stage)
