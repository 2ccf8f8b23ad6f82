# The experiment `matchers` (method §14, pipeline/experiments/matchers.py; its comparison job's rule is made by
# rules/jobs.smk): here the compared matchers' own attributes and predictors under matchers/<dataset>/<tag>/,
# the core rules `attributes` and `train` taken as they are (`use rule`: their shell line and settings declared once)
# with the experiment's paths and job records. Both records are computed from the wildcards alone, so that Snakemake
# compares them with the last run's (a param made from a rule's input or output is left out of that check).
from vpr_smr.pipeline.experiments import matchers as compared


use rule attributes as matcher_attributes with:
    output:
        matcher_attributes_path(OUT, "{dataset}", "{tag}", "{method}", "{seq_len}", "{split}"),
    log:
        log_path(OUT, matcher_attributes_path(OUT, "{dataset}", "{tag}", "{method}", "{seq_len}", "{split}")),
    wildcard_constraints:
        tag="|".join(map(re.escape, MATCHER_TAGS)) or "(?!)",  # no other matcher: the rule matches nothing
    params:
        job=lambda wc: job_text(compared.attributes_record(OUT, conf, PLAN, dict(wc.items()))),


use rule train as matcher_train with:
    input:
        unpack(lambda wc: compared.train_inputs(OUT, conf, dict(wc.items()))),
    output:
        models=matcher_predictor_paths(OUT, "{dataset}", "{tag}", "{seq_len}", conf.seeds),
        report=predictor_report_path(matcher_predictor_path(OUT, "{dataset}", "{tag}", "{seq_len}")),
    log:
        log_path(OUT, matcher_predictor_path(OUT, "{dataset}", "{tag}", "{seq_len}")),
    wildcard_constraints:
        tag="|".join(map(re.escape, MATCHER_TAGS)) or "(?!)",
    params:
        layout=RESULTS_LAYOUT,  # its files' layout: a run of an earlier one trains again
        job=lambda wc: job_text(compared.train_record(OUT, conf, dict(wc.items()))),
