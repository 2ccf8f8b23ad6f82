# vpr-smr workflow: `vpr-smr run configs/<run>.yaml` (or snakemake --configfile ... --profile pipeline/profiles/local).
# Every rule calls one `vpr-smr` subcommand; the maths lives in the package, not here.
import sys

from vpr_smr.pipeline.config import run_dir, validate
from vpr_smr.pipeline.workflow import preflight

CONFIG_FILE = workflow.configfiles[-1] if workflow.configfiles else None
if CONFIG_FILE is None:
    raise ValueError("no configuration: run `vpr-smr run configs/<run>.yaml` or pass --configfile")
conf = validate(config, CONFIG_FILE)
preflight(conf)  # missing roots or checkpoints fail here, before any job runs

OUT = str(run_dir(conf))
CLI = f"{sys.executable} -m vpr_smr.pipeline"
DATASETS = list(conf["datasets"])
METHODS = list(conf["methods"])
SEQ_LENS = conf["seq_lens"]
SPLITS = sorted({conf["train_split"], *conf["eval_splits"]})

wildcard_constraints:
    dataset="[A-Za-z0-9_.-]+",
    method="[A-Za-z0-9_.-]+",
    split="[A-Za-z0-9_.-]+",
    seq_len="[0-9]+",


include: "pipeline/rules/descriptors.smk"
include: "pipeline/rules/eval.smk"


rule all:
    input:
        f"{OUT}/tables/table1.csv",
        f"{OUT}/tables/predictor.csv",
