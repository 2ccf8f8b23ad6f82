"""Small user-facing promises, each on matrices no other test uses: the advice on a matrix too small for the
sequence length asked can be followed (a length it names works; none is named below the shortest); a constant or
all-tied matrix is named as such; every command that writes a file says so in one line with its headline."""

import re

import numpy as np
import pytest

from vpr_smr.eval.matching import attributes
from vpr_smr.eval.matching.checks import check_size, tie_warning
from vpr_smr.eval.matching.matchers import MATCHERS, MatcherSpec
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.scoring import vpr_metrics
from vpr_smr.eval.scoring.vpr_metrics import MetricsJob


def _refuse_above(longest):
    def check(seq_len):
        if seq_len > longest:
            raise ValueError(f"m does not fit {seq_len}")
    return check


@pytest.mark.parametrize("longest", [2, 3, 7, 64])
def test_the_advised_length_is_the_longest_that_fits(longest):
    with pytest.raises(ValueError, match=rf"^m does not fit 100; give a --seq-len of at most {longest}, or a larger "
                                         r"matrix$"):
        check_size(_refuse_above(longest), 100)
    check_size(_refuse_above(longest), longest)  # fits: no error


def test_a_matrix_no_length_fits_is_named_so_and_a_length_below_two_is_refused_first():
    with pytest.raises(ValueError, match=r"^m does not fit 2; 2 is the shortest sequence length, so no --seq-len "
                                         r"fits: give a larger matrix$"):
        check_size(_refuse_above(1), 5)
    with pytest.raises(ValueError, match=r"^--seq-len must be at least 2 \(.*\), got 1; besides, m does not fit 2; "):
        check_size(_refuse_above(1), 1)
    with pytest.raises(ValueError, match=r"^--seq-len must be at least 2 \(.*\), got 0$"):
        check_size(_refuse_above(9), 0)


def _stages(tmp_path, matcher):
    """The stages that match a matrix at a length: attributes, and metrics (queries shares its reading)."""
    spec = MatcherSpec.of(matcher)
    return {
        "attributes": lambda path, seq_len: attributes.main(attributes.AttributesJob(
            str(path), seq_len, TruthSource(tolerance=0), spec, out=str(tmp_path / "a.csv"))),
        "metrics": lambda path, seq_len: vpr_metrics.main(MetricsJob(
            (f"s={path}",), seq_len, TruthSource(tolerance=0), spec, baselines=False, out=str(tmp_path / "m.json"))),
    }


@pytest.mark.parametrize("matcher", sorted(MATCHERS))
@pytest.mark.parametrize("size", [1, 3, 14])
def test_every_matchers_advice_on_a_small_matrix_can_be_followed(tmp_path, matcher, size):
    path = tmp_path / f"d{size}.npy"
    rng = np.random.default_rng(size)
    np.save(path, rng.random((size, size)) + 5 * np.abs(np.subtract.outer(np.arange(size), np.arange(size))))
    for stage, run in _stages(tmp_path, matcher).items():
        try:
            run(path, 9)
            continue  # fits even 9
        except ValueError as error:
            message = str(error)
        assert "at most 1" not in message and "at most 0" not in message, (stage, message)
        advised = re.search(r"give a --seq-len of at most (\d+)", message)
        if advised is None:  # nothing fits: said in words, and the shortest length is refused too
            assert "so no --seq-len fits: give a larger matrix" in message, (stage, message)
            with pytest.raises(ValueError, match="no --seq-len fits"):
                run(path, 2)
        else:
            run(path, int(advised.group(1)))  # the advice works


def _tie_warnings(caplog):
    return [r.getMessage() for r in caplog.records if r.levelname == "WARNING" and "single value" in r.getMessage()]


@pytest.mark.parametrize("stage", ["attributes", "metrics"])
@pytest.mark.parametrize("values", [
    np.full((12, 12), 5.0),  # constant
    np.zeros((12, 12)),  # constant at 0
    np.tile(np.arange(12.0) * 3, (12, 1)),  # each column one value, another per column: all tied
])
def test_a_constant_or_all_tied_matrix_is_named_as_such(tmp_path, caplog, stage, values):
    path = tmp_path / "flat.npy"
    np.save(path, values)
    _stages(tmp_path, "seqslam")[stage](path, 3)
    warnings = _tie_warnings(caplog)
    assert len(warnings) == 1 and warnings[0].startswith(str(path)), warnings
    assert "every one of its 12 query columns holds a single value" in warnings[0]
    assert "every ranking is a tie" in warnings[0] and "not by the matrix" in warnings[0]


def test_tied_columns_are_counted_and_a_matrix_without_ties_passes_silently(tmp_path, caplog):
    rng = np.random.default_rng(44)
    values = rng.random((15, 15)) + 3 * np.abs(np.subtract.outer(np.arange(15), np.arange(15)))
    np.save(tmp_path / "plain.npy", values)
    values[:, [2, 9, 11]] = 7.25  # three queries whose every reference is equally far
    values[4, 5] = np.nan  # a NaN column is no tie (and is refused later, naming the value)
    np.save(tmp_path / "three.npy", values[:, :-1])
    _stages(tmp_path, "seqslam")["metrics"](tmp_path / "plain.npy", 3)
    assert _tie_warnings(caplog) == []
    assert tie_warning("three.npy", values[:, :-1]) == (
        "three.npy: 3 of its 14 query columns hold a single value: those queries' single-frame rankings are ties, "
        "decided by how ties are broken, not by the matrix")
    wide = np.tile(rng.random((1, 1000)), (6, 1))  # a sample of 256 of 1000 columns, every one tied
    assert tie_warning("wide", wide).startswith("wide: every one of 256 of its 1000 query columns read holds")


def _wrote_lines(caplog, out):
    return [r.getMessage() for r in caplog.records if r.getMessage().startswith("wrote ") and str(out) in
            r.getMessage()]


def _naive_sequence_correct(d, seq_len, tolerance):
    """Per query a >= L-1: whether the lowest diagonal sum's end reference is within ``tolerance`` of a (first on
    ties), summed in Python."""
    n_ref, n_query = d.shape
    correct = 0
    for a in range(seq_len - 1, n_query):
        sums = [sum(float(d[r - k, a - k]) for k in range(seq_len)) for r in range(seq_len - 1, n_ref)]
        best = seq_len - 1 + sums.index(min(sums))
        correct += abs(best - a) <= tolerance
    return correct, n_query - seq_len + 1


def test_every_stage_that_writes_a_file_says_what_where_and_its_headline(tmp_path, caplog, predictor_file):
    from helpers import write_distance_matrix

    from vpr_smr.core.records import load
    from vpr_smr.eval.scoring.records import VPRMetrics
    from vpr_smr.pipeline.cli import main as cli

    rng = np.random.default_rng(808)
    d = rng.random((26, 26)) + 0.5 * np.abs(np.subtract.outer(np.arange(26), np.arange(26))) % 3
    matrix = tmp_path / "test.h5"
    write_distance_matrix(matrix, d, {"dataset": "d", "method": "m", "split": "test", "split_range": [60, 86]})
    attributes_file = tmp_path / "test_L3.h5"
    caplog.set_level("INFO", logger="vpr_smr")
    assert cli(["attributes", "--distances", str(matrix), "--seq-len", "3", "--tolerance", "1",
                "--out", str(attributes_file)]) == 0
    correct, n = _naive_sequence_correct(d, 3, 1)
    assert _wrote_lines(caplog, attributes_file) == [
        f"wrote the attributes of {n} queries to {attributes_file}: {correct} sequence matches correct "
        f"({correct / n:.4f})"]

    metrics = tmp_path / "m.json"
    assert cli(["metrics", "--distances", str(matrix), "--seq-len", "3", "--tolerance", "1", "--no-baselines",
                "--modes", "standard", "--out", str(metrics)]) == 0
    written = load(metrics, VPRMetrics).splits["all"].modes["standard"]["sequence"].recall_at[1]
    assert _wrote_lines(caplog, metrics) == [
        f"wrote the metrics to {metrics}: all: sequence recall@1 {written:.4f} (standard mode)"]

    evaluation = tmp_path / "e.json"
    assert cli(["evaluate", "--dataset", "d", "--method", "m", "--seq-len", "3", "--attributes",
                f"test={attributes_file}", "--predictors", str(predictor_file), "--out", str(evaluation)]) == 0
    [line] = _wrote_lines(caplog, evaluation)
    assert re.fullmatch(rf"wrote the evaluation of m to {re.escape(str(evaluation))}: test: the seed-0 predictor "
                        rf"removes \d+ of {n} matches, macro F1 \d\.\d{{3}}", line), line

    baselines = tmp_path / "b.json"
    assert cli(["baselines", "--dataset", "d", "--method", "m", "--seq-len", "3", "--tolerance", "1",
                "--distances", f"test={matrix}", "--attributes", f"test={attributes_file}",
                "--predictors", str(predictor_file), "--r-window", "4", "--spread-k", "3",
                "--out", str(baselines)]) == 0
    [line] = _wrote_lines(caplog, baselines)
    assert line.startswith(f"wrote the training-free scorers of m to {baselines}: test: {n - correct} wrong sequence "
                           f"matches of {n}, average precision uniqueness "), line


def test_scikit_learns_fold_warning_is_said_in_our_words_naming_the_dataset(tmp_path, caplog):
    import warnings

    from training_sets import train_job, write_samples

    from vpr_smr.eval.predictor import train

    rng = np.random.default_rng(2044)
    y = np.array([0] * 27 + [1] * 9 + [2] * 7 + [3] * 3)  # class 3: 3 samples for 5 folds
    x = rng.normal(size=(len(y), 4)) + y[:, None] * np.array([0.9, -0.4, 0.5, 1.2])
    write_samples(tmp_path / "few.h5", x, y)
    caplog.set_level("INFO")
    with warnings.catch_warnings(record=True) as escaped:
        warnings.simplefilter("always")
        train.main(train_job([tmp_path / "few.h5"], tmp_path / "p.h5", {"hidden_layer_sizes": [6], "max_iter": 30},
                             dataset="tiny_route", seq_len=3))
    assert [str(w.message) for w in escaped if "sklearn" in w.filename] == []
    [line] = [r.getMessage() for r in caplog.records if "cross-validated on class counts" in r.getMessage()]
    assert line.startswith("dataset 'tiny_route', sequence length 3, train split of 1 method(s) pooled, "
                           "cross-validated on class counts 0: 27, 1: 9, 2: 7, 3: 3: class 3 has 3 samples for 5 "
                           "folds, so 2 of the folds test without it: the cross-validated F1 ")


def test_each_kind_of_fold_warning_gets_its_meaning():
    from sklearn.exceptions import ConvergenceWarning, UndefinedMetricWarning

    from vpr_smr.eval.predictor.estimator import fold_warning

    labels = np.array([0, 0, 0, 0, 1, 1, 1, 2, 2, 2])
    assert fold_warning([], labels, 4, "here") is None
    line = fold_warning([UserWarning("The least populated class in y has only 3 members, which is less than "
                                     "n_splits=4."), UndefinedMetricWarning("F-score is ill-defined"),
                         ConvergenceWarning("Stochastic Optimizer: Maximum iterations (5) reached"),
                         ConvergenceWarning("again")], labels, 4, "here")
    assert line.startswith("here, cross-validated on class counts 0: 4, 1: 3, 2: 3, 3: 0: class 1 has 3 samples for "
                           "4 folds, so 1 of the folds test without it")
    assert "its F1 there counts as 0" in line and line.count("before converging") == 1  # one phrase per kind


# Snakemake 9's dry run of a copy made with `cp -r` (file times not kept; trimmed): a descriptors file over Snakemake's
# 1 MB checksum size came out newer than the report's outputs
COPIED_DRY_RUN = """\
Building DAG of jobs...
Job stats:
job       count
------  -------
report        1
all           1
total         2

[Mon Dec  7 16:44:01 2026]
rule report:
    input: results/r/evaluation/sample/sad/L3.json, results/r/descriptors/sample/hog.h5
    output: results/r/tables/table1.csv, results/r/tables/table1.md
    log: results/r/logs/report.log
    jobid: 1
    reason: Updated input files: results/r/descriptors/sample/hog.h5
    resources: tmpdir=/tmp
[Mon Dec  7 16:44:01 2026]
localrule evaluate:
    input: results/r/attributes/sample/sad/L3/val.h5
    output: results/r/evaluation/sample/sad/L3.json, results/r/evaluation/sample/sad/L3.timing.json
    jobid: 2
    reason: Params have changed since last execution: ...
[Mon Dec  7 16:44:01 2026]
rule train:
    output: results/r/predictors/sample/L3.h5
    jobid: 3
    reason: Forced execution
[Mon Dec  7 16:44:01 2026]
rule all:
    input: results/r/tables/table1.csv, results/r/tables/table1.md
    jobid: 0
    reason: Input files updated by another job: results/r/tables/table1.csv
    resources: tmpdir=/tmp
Job stats:
job       count
------  -------
report        1
all           1
total         2
"""


def test_a_dry_run_names_why_each_job_runs():
    import io

    from vpr_smr.pipeline.console import DryRunView

    out, err = io.StringIO(), io.StringIO()
    view = DryRunView(out, err)
    for line in COPIED_DRY_RUN.splitlines(keepends=True):
        view.feed(line)
    view.close(0)
    shown = out.getvalue().splitlines()
    why = shown[shown.index("Why they run:") + 1 : -1]
    assert why == [
        "  results/r/tables/table1.csv (report): its input results/r/descriptors/sample/hog.h5 is newer than its "
        "outputs; Snakemake compares the contents only of inputs under 1 MB, so after a copy that did not keep file "
        "times (cp -r; cp -a keeps them) it reruns",
        "  results/r/evaluation/sample/sad/L3.json (evaluate): Params have changed since last execution: ..."]
    assert shown[-1].startswith("This was a dry run") and err.getvalue() == ""


def test_a_first_dry_run_counts_the_jobs_whose_outputs_are_not_there():
    from vpr_smr.pipeline.console import why_jobs_run

    lines = [*"rule a:\n    output: x\n    reason: Missing output files: x\nrule b:\n    output: y\n    reason: "
             "Missing output files: y\nrule all:\n    reason: Input files updated by another job: x, y".splitlines()]
    assert why_jobs_run(lines) == ["", "Why they run:", "  2 jobs: outputs not there yet"]
    assert why_jobs_run(["Nothing to be done (all requested files are present and up to date)."]) == []


def test_the_final_fits_warnings_are_said_in_our_words_and_none_escapes(caplog):
    """The fit after the cross-validation, and its scoring on an evaluation split, warn through one line of ours."""
    import warnings

    from vpr_smr.eval.predictor.train import train_seed

    rng = np.random.default_rng(44)
    x = rng.random((60, 4))
    y = np.repeat([0, 1, 2, 3], 15)
    # an evaluation split of one class (macro_f1 scores absent classes 0 without a warning of scikit-learn's)
    evaluation = {"val": (rng.random((8, 4)), np.zeros(8, dtype=np.int64))}
    with warnings.catch_warnings(record=True) as escaped, caplog.at_level("WARNING", logger="vpr_smr"):
        warnings.simplefilter("always")
        train_seed(x, y, {"hidden_layer_sizes": [3], "max_iter": 2}, 0, evaluation, cross_validate=False,
                   where="dataset 'q', L 3")
    lines = [r.getMessage() for r in caplog.records if "seed 0" in r.getMessage()]
    assert len(lines) == 1
    assert lines[0].startswith("dataset 'q', L 3, seed 0: the network stopped at its max_iter before converging")
    assert not [w for w in escaped if "sklearn" in w.filename or "imblearn" in w.filename]
