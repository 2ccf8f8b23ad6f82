"""The stages metrics, queries and baselines as declared stages (``pipeline.stages.scoring``): every option of their
earlier command lines gives the job record written here by hand, ``--job`` with the record's text (what the
workflow's rules give) gives the same record back, and ``--distances`` of metrics and queries still takes one PATH or
SPLIT=PATH items."""


import pytest
from stage_jobs import check_old_command

from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.sources import MatrixFormat, TruthSource
from vpr_smr.eval.scoring.matrix_jobs import BaselinesJob, MetricsJob, QueriesJob, distance_splits
from vpr_smr.eval.scoring.scorers import BaselineSettings
from vpr_smr.pipeline.cli import build_parser
from vpr_smr.pipeline.stage import job_of
from vpr_smr.pipeline.stages import scoring

TRUTH = ["--tolerance", "3", "--reference-positions", "r.csv", "--query-positions", "q.npy", "--radius", "7.5",
         "--ground-truth", "gt.mat", "--ground-truth-key", "GThard"]
GIVEN_TRUTH = TruthSource(3, "r.csv", "q.npy", 7.5, "gt.mat", "GThard")
MATCHER = ["--matcher", "seqslam", "--velocities", "0.8", "1.0", "1.25"]
GIVEN_MATCHER = MatcherSpec.of("seqslam", {"velocities": [0.8, 1.0, 1.25]})
READING = ["--similarity", "--key", "S", "--transpose"]

# (stage, the earlier command line, the job it means)
OLD_COMMANDS = [
    (scoring.METRICS,  # every option, as the workflow's rule gave them and more
     ["metrics", "--dataset", "route", "--method", "sad", "--seq-len", "3", *TRUTH, *MATCHER, "--distances",
      "val=v.h5", "test=t 1.h5", "--attributes", "val=va.h5", "test=ta.h5", "--predictor", "L3.h5", "--r-window",
      "6", "--spread-k", "5", "--modes", "standard", "--sweep", "--queries", "q.csv", *READING, "--out", "m.json",
      "--allow-split-overlap"],
     MetricsJob(("val=v.h5", "test=t 1.h5"), 3, GIVEN_TRUTH, GIVEN_MATCHER, MatrixFormat(True, "S", True), "L3.h5",
                {"val": "va.h5", "test": "ta.h5"}, ("standard",), "q.csv", True, "route", "sad", True,
                BaselineSettings(6, 5), True, "m.json")),
    (scoring.METRICS,  # a user's matrix: the defaults of everything else
     ["metrics", "--distances", "D.npy", "--seq-len", "4", "--out", "m.json"],
     MetricsJob(("D.npy",), 4, out="m.json")),
    (scoring.METRICS,
     ["metrics", "--distances", "D.npy", "--seq-len", "4", "--no-baselines", "--out", "m.json"],
     MetricsJob(("D.npy",), 4, baselines=False, out="m.json")),
    (scoring.QUERIES,
     ["queries", "--seq-len", "3", *TRUTH, *MATCHER, "--distances", "val=v.h5", "test=t.h5", "--attributes",
      "val=va.h5", "--predictor", "L3.h5", "--r-window", "4", "--spread-k", "3", *READING, "--out", "q.csv",
      "--allow-split-overlap"],
     QueriesJob(("val=v.h5", "test=t.h5"), 3, GIVEN_TRUTH, GIVEN_MATCHER, MatrixFormat(True, "S", True), "L3.h5",
                {"val": "va.h5"}, True, BaselineSettings(4, 3), True, "q.csv")),
    (scoring.QUERIES,
     ["queries", "--distances", "D.npy", "--seq-len", "4", "--no-baselines", "--out", "q.csv"],
     QueriesJob(("D.npy",), 4, baselines=False, out="q.csv")),
    (scoring.BASELINES,
     ["baselines", "--dataset", "route", "--method", "sad", "--seq-len", "3", *TRUTH, *MATCHER, "--distances",
      "val=v.h5", "test=t.h5", "--attributes", "val=va.h5", "test=ta.h5", "--predictors", "L3.h5", "L3.seed1.h5",
      "--r-window", "6", "--spread-k", "5", "--modes", "paper", *READING, "--out", "b.json", "--allow-split-overlap"],
     BaselinesJob("route", "sad", 3, {"val": "v.h5", "test": "t.h5"}, {"val": "va.h5", "test": "ta.h5"},
                  ("L3.h5", "L3.seed1.h5"), GIVEN_TRUTH, GIVEN_MATCHER, MatrixFormat(True, "S", True),
                  BaselineSettings(6, 5), ("paper",), True, "b.json")),
    (scoring.BASELINES,  # another matcher and its settings; the defaults of the others
     ["baselines", "--dataset", "d", "--method", "m", "--seq-len", "4", "--distances", "test=t.h5", "--attributes",
      "test=ta.h5", "--predictors", "L4.h5", "--matcher", "monotone", "--max-step", "3", "--out", "b.json"],
     BaselinesJob("d", "m", 4, {"test": "t.h5"}, {"test": "ta.h5"}, ("L4.h5",),
                  matcher=MatcherSpec.of("monotone", {"max_step": 3}), out="b.json")),
]


@pytest.mark.parametrize("stage, argv, expected", OLD_COMMANDS,
                         ids=[f"{stage.command}-{i}" for i, (stage, _, _) in enumerate(OLD_COMMANDS)])
def test_the_old_command_lines_give_the_job(stage, argv, expected):
    check_old_command(stage, argv, expected)


def test_the_defaults_are_the_earlier_commands():
    job = MetricsJob(("D.npy",), 4, out="m.json")
    assert job.truth.tolerance == 2 and job.modes == ("paper", "standard") and job.matcher == MatcherSpec.of()
    assert job.scorer_settings == BaselineSettings(10, 10)  # the scorers on, at method §12's settings
    assert MetricsJob(("D.npy",), 4, baselines=False, out="m.json").scorer_settings is None
    assert QueriesJob(("D.npy",), 4, baselines=False, out="q.csv").scorer_settings is None


def test_distances_is_one_path_or_split_items(tmp_path):
    assert distance_splits(("D.npy",)) == {"all": "D.npy"}
    assert distance_splits(("val=v.h5", "test=t=1.h5")) == {"val": "v.h5", "test": "t=1.h5"}
    odd = tmp_path / "a=b.npy"  # a file whose name holds "=": one path still
    odd.touch()
    assert distance_splits((str(odd),)) == {"all": str(odd)}
    with pytest.raises(ValueError, match=r"^--distances takes SPLIT=PATH items, got a.npy, b.npy$"):
        distance_splits(("a.npy", "b.npy"))


def test_the_earlier_switches_still_parse():
    """--no-baselines and --allow-split-overlap as before; the scorers' settings options of the baselines command."""
    argv = ["metrics", "--distances", "D.npy", "--seq-len", "4", "--no-baselines", "--allow-split-overlap",
            "--out", "m.json"]
    job = job_of(scoring.METRICS, build_parser().parse_args(argv))
    assert (job.baselines, job.allow_split_overlap) == (False, True)
    with pytest.raises(SystemExit):  # the baselines command scores the scorers: it has no --no-baselines
        build_parser().parse_args(["baselines", "--dataset", "d", "--method", "m", "--seq-len", "4", "--distances",
                                   "test=t.h5", "--attributes", "test=a.h5", "--predictors", "p.h5",
                                   "--no-baselines", "--out", "b.json"])
