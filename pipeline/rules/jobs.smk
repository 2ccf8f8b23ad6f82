# Every declared job a rule, calling its stage with its job record (`vpr-smr COMMAND --job JSON`): the core
# workflow's (pipeline.core_jobs: descriptors, distances, attributes, train, evaluate, the ablations, the scorers, the
# inspector) and those of the experiments the configuration turns on, the tool's own (pipeline/experiments/) and those
# installed packages register (pipeline.experiment); the report waits for their files. Each rule comes from its job's
# declaration (pipeline.experiment.Job): its inputs, outputs, log, threads, resources and params; the job record is
# computed from the wildcards alone (Job.job_record), so that Snakemake compares it with the last run's: a param made
# from a rule's input or output is left out of that check.
from vpr_smr.pipeline.core_jobs import JOBS as CORE_JOBS
from vpr_smr.pipeline.experiment import running


# A function, not a loop's body: Snakemake evaluates a rule's shell command again when the job runs, in the scope the
# rule was written in; a loop's variable is then its last value (every rule would run the last job's stage), a
# call's argument is its own.
def declare(name, job):

    rule:
        name:
            name
        input:
            unpack(lambda wc: dict(job.inputs(OUT, conf, PLAN, dict(wc.items())))),
        output:
            *job.listed_outputs(OUT),
            **job.named_outputs(OUT, conf),
        log:
            log_path(OUT, f"{OUT}/{job.output}"),
        wildcard_constraints:
            **job.constraints(conf, PLAN),
        threads: job.threads or 1
        resources:
            **job.rule_resources(conf),
        params:
            **job.rule_params(OUT, conf, PLAN),
        shell:
            job.shell_prefix + shell_command(job.stage, job.speed)


for _job in CORE_JOBS:
    declare(_job.rule, _job)
for _experiment in running(EXPERIMENTS):
    for _job in _experiment.jobs:
        declare(_experiment.rule_name(_job), _job)
