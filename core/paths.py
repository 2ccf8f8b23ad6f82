"""Every output path of a run, one function per kind: the Snakemake rules and the stages both name files here.

A function takes the run folder and the names (a rule passes wildcard strings such as ``"{dataset}"``) and returns
the path as text joined with ``/``, as the rules write it. A file that lives beside another (a predictor's other
seeds and its report, an evaluation's timings, a job's log) is named from that file, so that a stage given only
its ``--out`` derives it the same way as the workflow declares it.
"""

from __future__ import annotations

from pathlib import Path, PurePath


def _without_suffix(path: Path | str) -> str:
    """``path`` as text without its last suffix (``.../L4.h5`` -> ``.../L4``), keeping the text as given."""
    text = str(path)
    return text[:len(text) - len(PurePath(text).suffix)]


def descriptors_path(run: Path | str, dataset: str, method: str) -> str:
    return f"{run}/descriptors/{dataset}/{method}.h5"


def distances_path(run: Path | str, dataset: str, method: str, split: str) -> str:
    return f"{run}/distances/{dataset}/{method}/{split}.h5"


def attributes_path(run: Path | str, dataset: str, method: str, seq_len: int | str, split: str) -> str:
    """The attributes stage's file (attributes, labels, matches) of one split at sequence length ``seq_len``."""
    return f"{run}/attributes/{dataset}/{method}/L{seq_len}/{split}.h5"


def predictor_path(run: Path | str, dataset: str, seq_len: int | str) -> str:
    """The pooled predictor of seed 0 (the authors' recipe); the other seeds go beside it (``seed_predictor_path``)."""
    return f"{run}/predictors/{dataset}/L{seq_len}.h5"


def seed_predictor_path(predictor: Path | str, seed: int) -> str:
    """Seed ``seed``'s predictor beside the first seed's ``predictor``: ``L4.h5`` -> ``L4.seed<seed>.h5``."""
    return f"{_without_suffix(predictor)}.seed{seed}.h5"


def predictor_paths(run: Path | str, dataset: str, seq_len: int | str, seeds: int) -> list[str]:
    """The predictors of seeds ``0..seeds-1``, seed 0 first."""
    first = predictor_path(run, dataset, seq_len)
    return [first] + [seed_predictor_path(first, seed) for seed in range(1, seeds)]


def predictor_report_path(predictor: Path | str) -> str:
    """The training report beside a predictor file: ``L4.h5`` -> ``L4.json``."""
    return f"{_without_suffix(predictor)}.json"


def without_predictor_path(run: Path | str, dataset: str, seq_len: int | str, method: str) -> str:
    """The leave-one-method-out predictor, trained on every method but ``method``."""
    return f"{run}/predictors/{dataset}/L{seq_len}/without_{method}.h5"


def evaluation_path(run: Path | str, dataset: str, method: str, seq_len: int | str) -> str:
    return f"{run}/evaluation/{dataset}/{method}/L{seq_len}.json"


def timing_path(evaluation: Path | str) -> str:
    """The timings beside an evaluation file: ``L4.json`` -> ``L4.timing.json`` (apart, so results repeat exactly)."""
    return f"{_without_suffix(evaluation)}.timing.json"


def vpr_metrics_path(run: Path | str, dataset: str, method: str, seq_len: int | str) -> str:
    """The standard VPR metrics of one method at one L (``eval.scoring.vpr_metrics``), every evaluated split."""
    return f"{run}/metrics/{dataset}/{method}/L{seq_len}.json"


def baselines_path(run: Path | str, dataset: str, method: str, seq_len: int | str) -> str:
    """The training-free baselines of one method at one L (``vpr-smr baselines``, method §12), every evaluated split."""
    return f"{run}/baselines/{dataset}/{method}/L{seq_len}.json"


def queries_path(run: Path | str, dataset: str, method: str, seq_len: int | str) -> str:
    """One row per evaluated query of every evaluated split: matches, distances, attributes, label, prediction."""
    return f"{run}/queries/{dataset}/{method}/L{seq_len}.csv"


def match_figure_path(run: Path | str, dataset: str, method: str, seq_len: int | str) -> str:
    """The match inspector: thumbnails of a fixed sample of test queries with their matches."""
    return f"{run}/figures/matches_{dataset}_{method}_L{seq_len}.png"


def matrix_figure_path(run: Path | str, dataset: str, method: str, seq_len: int | str) -> str:
    """The test split's distance matrix with the ground-truth band and the sequence matches, kept or removed."""
    return f"{run}/figures/distance_matrix_{dataset}_{method}_L{seq_len}.png"


def attribute_ablation_path(run: Path | str, dataset: str, seq_len: int | str) -> str:
    return f"{run}/ablation/attributes/{dataset}/L{seq_len}.json"


def held_out_path(run: Path | str, dataset: str, seq_len: int | str, method: str) -> str:
    """The held-out scores of ``method`` under the pooled and the ``without_<method>`` predictor."""
    return f"{run}/ablation/without/{dataset}/L{seq_len}/{method}.json"


def speed_path(run: Path | str, dataset: str, seq_len: int | str, profile: str) -> str:
    """The speed experiment of one dataset under one simulated speed profile (``eval.scoring.speed``), e.g.
    ``speed/nordland/L4/0.5x.json``."""
    return f"{run}/speed/{dataset}/L{seq_len}/{profile}.json"


def matcher_attributes_path(run: Path | str, dataset: str, tag: str, method: str, seq_len: int | str,
                            split: str) -> str:
    """The attributes of one split under a matcher of the experiment ``matchers`` other than the run's own
    (``tag``: ``eval.scoring.matcher_comparison.matcher_tag``), e.g.
    ``matchers/nordland/bayes_filter/attributes/sad/L4/test.h5``."""
    return f"{run}/matchers/{dataset}/{tag}/attributes/{method}/L{seq_len}/{split}.h5"


def matcher_predictor_path(run: Path | str, dataset: str, tag: str, seq_len: int | str) -> str:
    """The seed-0 predictor of a matcher of the experiment ``matchers`` other than the run's own, trained on its
    attributes (the other seeds beside it, ``seed_predictor_path``)."""
    return f"{run}/matchers/{dataset}/{tag}/predictors/L{seq_len}.h5"


def matcher_predictor_paths(run: Path | str, dataset: str, tag: str, seq_len: int | str, seeds: int) -> list[str]:
    """The predictors of such a matcher, seeds ``0..seeds-1``, seed 0 first."""
    first = matcher_predictor_path(run, dataset, tag, seq_len)
    return [first] + [seed_predictor_path(first, seed) for seed in range(1, seeds)]


def matchers_path(run: Path | str, dataset: str, method: str, seq_len: int | str) -> str:
    """The experiment ``matchers`` of one dataset and method (``eval.scoring.matcher_comparison``), e.g.
    ``matchers/nordland/sad/L4.json``."""
    return f"{run}/matchers/{dataset}/{method}/L{seq_len}.json"


def deployment_path(run: Path | str, dataset: str, method: str, seq_len: int | str) -> str:
    """The experiment deployment's result of one dataset and method at one L (method §16), every matcher's."""
    return f"{run}/deployment/{dataset}/{method}/L{seq_len}.json"


def adaptive_path(run: Path | str, dataset: str, tag: str, method: str) -> str:
    """The experiment ``adaptive_seq_len`` of one dataset, matcher (its tag, as the experiment ``matchers`` names
    it) and method (``eval.scoring.adaptive``), every length of the run, e.g. ``adaptive/nordland/seqslam/sad.json``;
    its live timings beside it (``timing_path``)."""
    return f"{run}/adaptive/{dataset}/{tag}/{method}.json"


def log_path(run: Path | str, output: Path | str) -> str:
    """The log of the job writing ``output`` (a path under ``run``): ``logs/`` plus its place in the run, ``.log``."""
    prefix = f"{run}/"
    if not str(output).startswith(prefix):
        raise ValueError(f"{output} is not under the run folder {run}")
    return f"{run}/logs/{_without_suffix(str(output)[len(prefix):])}.log"


def report_log_path(run: Path | str) -> str:
    return f"{run}/logs/report.log"


def recipes_path(run: Path | str) -> str:
    """What made each output of the run (``pipeline.recipes``): its rule's settings and the files it read."""
    return f"{run}/recipes.json"


# What `vpr-smr run` keeps between runs, in Snakemake's folder of the working folder (which cluster jobs see too):
# configuration overrides, the plan of the check before the first job, the methods whose check passed.
WORKFLOW_STATE = Path(".snakemake", "vpr-smr")


def overrides_path(digest: str) -> Path:
    return WORKFLOW_STATE / f"overrides-{digest[:16]}.yaml"


def plan_path(digest: str) -> Path:
    return WORKFLOW_STATE / f"plan-{digest[:16]}.json"


def methods_checked_path() -> Path:
    return WORKFLOW_STATE / "methods-checked.json"
