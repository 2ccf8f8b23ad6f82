# Every declared job a rule, calling its stage with its job record (`vpr-smr COMMAND --job JSON`): the core
# workflow's (pipeline.core_jobs: descriptors, distances, attributes, train, evaluate, the ablations, the scorers, the
# inspector) and those of the experiments the configuration turns on, the tool's own (pipeline/experiments/) and those
# installed packages register (pipeline.experiment); the report waits for their files. Each rule comes from its job's
# declaration (pipeline.experiment.Job): its inputs, outputs, log, threads, resources and params; the job record is
# computed from the wildcards alone (Job.job_record), so that Snakemake compares it with the last run's: a param made
# from a rule's input or output is left out of that check.
from vpr_smr.pipeline.core_jobs import JOBS as CORE_JOBS
from vpr_smr.pipeline.experiment import running

DECLARED = [(job.rule, job) for job in CORE_JOBS] + [
    (experiment.rule_name(job), job) for experiment in running(EXPERIMENTS) for job in experiment.jobs]

for _name, _job in DECLARED:

    rule:
        name:
            _name
        input:
            unpack(lambda wc, job=_job: dict(job.inputs(OUT, conf, PLAN, dict(wc.items())))),
        output:
            *_job.listed_outputs(OUT),
            **_job.named_outputs(OUT, conf),
        log:
            log_path(OUT, f"{OUT}/{_job.output}"),
        wildcard_constraints:
            **_job.constraints(conf, PLAN),
        threads: _job.threads or 1
        resources:
            **_job.rule_resources(conf),
        params:
            **_job.rule_params(OUT, conf, PLAN),
        shell:
            _job.shell_prefix + shell_command(_job.stage, _job.speed)
