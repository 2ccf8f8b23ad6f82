"""The Python API (``vpr_smr.api``): each function against values worked out by hand or by a naive implementation
written here; the CLI stage's numbers for the same matrix only as a wiring check beside them; bad arguments give
errors naming the argument and the fix; ``__all__`` is documented; ``import vpr_smr`` gives the version and the API;
the records the API returns are all in ``vpr_smr.records``; the old ``vpr_smr.pipeline.api`` still works and warns."""

from __future__ import annotations

import csv
import dataclasses
import inspect
import json
import subprocess
import sys
import tomllib
import types
import typing

import numpy as np
import pytest
from helpers import REPO, make_features
from sample_matrix import sample_distances as naive_sample_distances
from scipy.io import savemat
from sklearn.metrics import average_precision_score, f1_score
from sklearn.utils import shuffle

from vpr_smr import api as smr
from vpr_smr import records
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.pipeline.cli import main as cli

# A hand-worked matrix (references x queries), tolerance 0: the single-frame matches are r0, r1, r1 (q2 wrong);
# SeqSLAM at L=2 scores end reference r of query a as D[r-1, a-1] + D[r, a]:
#   a=1: r1 0.1 + 0.2 = 0.3, r2 0.7 + 0.3 = 1.0 -> r1 (correct)
#   a=2: r1 0.9 + 0.1 = 1.0, r2 0.2 + 0.4 = 0.6 -> r2 (correct)
D = np.array([[0.1, 0.9, 0.8],
              [0.7, 0.2, 0.1],
              [0.6, 0.3, 0.4]])
SMALL = {"hidden_layer_sizes": [16, 16]}  # a small network: the recipe is the same, the test quick


@pytest.fixture(scope="module")
def sample():
    """The sample's first 120 train and val frames with SAD, and their features at L=4."""
    train = smr.sample_distances("train", frames=120)
    val = smr.sample_distances("val", frames=120)
    return {"train": smr.attributes(train, 4), "val": smr.attributes(val, 4), "val_distances": val}


def naive_seqslam(distances: np.ndarray, seq_len: int) -> tuple[np.ndarray, np.ndarray]:
    """Every evaluated query's scores over the end references (inf where no diagonal ends) and its match, summed
    frame by frame."""
    n_ref, n_query = distances.shape
    scores = np.full((n_query - seq_len + 1, n_ref), np.inf)
    for row, a in enumerate(range(seq_len - 1, n_query)):
        for r in range(seq_len - 1, n_ref):
            scores[row, r] = sum(distances[r - k, a - k] for k in range(seq_len))
    return scores, np.argmin(scores, axis=1)


# --- the sample, and reading files ------------------------------------------------------------------------------


def test_sample_distances_are_sad_of_the_shipped_frames():
    found = smr.sample_distances("train", "sad", frames=12)
    # the SAD descriptor written out with OpenCV (tests/sample_matrix.py): equal up to float32 storage
    assert found.shape == (12, 12)
    np.testing.assert_allclose(found, naive_sample_distances(1, 12), atol=1e-5)


def test_read_distances_of_each_format(tmp_path):
    matrix = np.arange(12, dtype=np.float64).reshape(3, 4)
    np.save(tmp_path / "d.npy", matrix)
    np.savez(tmp_path / "d.npz", D=matrix, other=matrix)
    savemat(tmp_path / "d.mat", {"S": 11 - matrix.T})  # queries x references similarities
    assert np.array_equal(smr.read_distances(tmp_path / "d.npy"), matrix)
    assert np.array_equal(smr.read_distances(tmp_path / "d.npz", key="D"), matrix)
    # max(S) - S of the similarities 11 - D is D again (integers: exact)
    assert np.array_equal(smr.read_distances(tmp_path / "d.mat", similarity=True, transpose=True), matrix)


def test_read_ground_truth_of_a_mat_file(tmp_path):
    hard = np.eye(3, dtype=bool)
    savemat(tmp_path / "gt.mat", {"GThard": hard, "GTsoft": np.ones((3, 3), bool)})
    truth = smr.read_ground_truth(tmp_path / "gt.mat", key="GThard", shape=(3, 3))
    references, queries = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
    assert np.array_equal(truth.correct(references, queries), hard)


# --- metrics, matching, attributes ------------------------------------------------------------------------------


def test_metrics_of_the_hand_worked_matrix():
    found = smr.metrics(D, 2, tolerance=0)
    standard, paper = found.modes["standard"], found.modes["paper"]
    # single recall@1: 2 of the 3 queries (paper: every query), 1 of the evaluated queries 1, 2 (standard)
    assert paper["single"].recall_at[1] == pytest.approx(2 / 3)
    assert standard["single"].recall_at[1] == 0.5
    assert standard["single"].recall_at[5] == 1.0  # every reference is within 5
    # standard single: the closest match (0.1, q2) is wrong, so no threshold has precision 1: R@100P 0, EP 0
    assert standard["single"].recall_at_100p == 0.0 and standard["single"].extended_precision == 0.0
    # paper single: q0 (correct) and q2 (wrong) tie at 0.1: P_R0 = 1/2, R@100P 0, EP (1/2 + 0) / 2
    assert paper["single"].extended_precision == 0.25
    # sequence: both matches correct, precision 1 at every recall
    assert standard["sequence"].recall_at[1] == 1.0
    assert standard["sequence"].recall_at_100p == 1.0 and standard["sequence"].extended_precision == 1.0
    assert standard["sequence"].pr_auc == 1.0


def test_metrics_with_a_ground_truth_matrix():
    truth = np.eye(3, dtype=bool)
    truth[1, 2] = True  # q2's single-frame match r1 is correct too
    found = smr.metrics(D, 2, ground_truth=truth)
    assert found.modes["paper"]["single"].recall_at[1] == 1.0


def test_metrics_equal_the_cli_stage(tmp_path, sample):
    """Wiring: the same numbers as vpr-smr metrics writes for the same matrix (the checks above are the
    independent ones)."""
    np.save(tmp_path / "d.npy", sample["val_distances"])
    assert cli(["metrics", "--distances", str(tmp_path / "d.npy"), "--seq-len", "4", "--no-baselines",
                "--out", str(tmp_path / "m.json")]) in (0, None)
    written = json.loads((tmp_path / "m.json").read_text())["splits"]["all"]["modes"]
    assert smr.plain(smr.metrics(sample["val_distances"], 4))["modes"] == written


def test_match_scores_are_the_sums_by_hand():
    found = smr.match(D, 2)
    assert list(found.queries) == [1, 2]
    assert list(found.match) == [1, 2]
    assert found.scores[0, 1] == pytest.approx(0.1 + 0.2) and found.scores[0, 2] == pytest.approx(0.7 + 0.3)
    assert found.scores[1, 1] == pytest.approx(0.9 + 0.1) and found.scores[1, 2] == pytest.approx(0.2 + 0.4)
    assert np.isinf(found.scores[:, 0]).all()  # no diagonal of length 2 ends at r0


def test_match_by_name_with_settings_against_a_naive_seqslam(sample):
    distances = sample["val_distances"][:40, :40]
    scores, match = naive_seqslam(distances, 3)
    found = smr.match(distances, 3, matcher="seqslam", settings={"velocities": [1.0]})
    np.testing.assert_allclose(found.scores[:, 2:], scores[:, 2:], rtol=1e-12)
    assert np.array_equal(found.match, match)
    other = smr.match(distances, 3, matcher="monotone", settings={"max_step": 1})
    assert len(other.queries) == len(other.match) and other.scores.shape[1] == 40


def test_attributes_labels_by_hand(tmp_path):
    found = smr.attributes(D, 2, tolerance=0)
    assert list(found.queries) == [1, 2]
    # q1: correct before and after (0); q2: wrong before, correct after (2)
    assert list(found.labels) == [0, 2]
    assert list(found.sequence_match) == [1, 2]
    assert found.sequence_distance == pytest.approx([0.3, 0.6])
    # wiring: the rank-0 attributes the attributes stage writes for the same matrix
    np.save(tmp_path / "d.npy", D)
    cli(["attributes", "--distances", str(tmp_path / "d.npy"), "--seq-len", "2", "--tolerance", "0",
         "--out", str(tmp_path / "a.csv")])
    rows = list(csv.DictReader((tmp_path / "a.csv").open()))
    written = np.array([[float(row[f"A{k}"]) for k in range(1, 5)] for row in rows])
    np.testing.assert_allclose(found.attributes[:, 0, :], written, rtol=1e-8)


# --- the predictor, evaluation, scorers ------------------------------------------------------------------------


def test_train_is_the_seeded_recipe(sample):
    features = sample["train"]
    x, y = features.attributes[:, 0, :], features.labels
    for seed in (0, 1):
        found = smr.train(features, seed=seed, settings=SMALL)
        # the recipe written out: shuffle with the seed, the MLP's and SMOTE's seeds (0 and 42) shifted by it
        xs, ys = shuffle(x, y, random_state=seed)
        expected = SMRPredictor(hidden_layer_sizes=(16, 16), random_state=seed, smote_random_state=42 + seed)
        expected.fit(xs, ys)
        np.testing.assert_array_equal(found.predict_proba(x), expected.predict_proba(x))


def test_predict_keeps_the_classes_0_and_2(sample):
    predictor = smr.train(sample["train"], settings=SMALL)
    decision = smr.predict(predictor, sample["val"])
    probabilities = predictor.predict_proba(sample["val"].attributes[:, 0, :])
    predicted = predictor.classes_[np.argmax(probabilities, axis=1)]
    assert np.array_equal(decision.predicted, predicted)
    assert np.array_equal(decision.kept, np.isin(predicted, (0, 2)))


def test_a_saved_predictor_loads_and_the_cli_applies_it(tmp_path, sample):
    """save_predictor then load_predictor gives the same probabilities; vpr-smr metrics --predictor reads the file
    and removes what the in-memory predictor removes."""
    predictor = smr.train(sample["train"], settings=SMALL)
    smr.save_predictor(predictor, tmp_path / "p.h5")
    loaded = smr.load_predictor(tmp_path / "p.h5")
    x = sample["val"].attributes[:, 0, :]
    np.testing.assert_array_equal(loaded.predict_proba(x), predictor.predict_proba(x))
    assert [p.name for p in tmp_path.iterdir()] == ["p.h5"]  # written under a temporary name, then renamed
    np.save(tmp_path / "d.npy", sample["val_distances"])
    assert cli(["metrics", "--distances", str(tmp_path / "d.npy"), "--seq-len", "4", "--no-baselines",
                "--predictor", str(tmp_path / "p.h5"), "--out", str(tmp_path / "m.json")]) in (0, None)
    written = json.loads((tmp_path / "m.json").read_text())["splits"]["all"]["modes"]["standard"]
    found = smr.plain(smr.metrics(sample["val_distances"], 4, predictor=predictor))["modes"]["standard"]
    assert written["sequence_predictor"] == found["sequence_predictor"]
    removed = int(np.sum(~smr.predict(predictor, sample["val"]).kept))
    assert 0 < removed < len(x)  # the comparison above is of a removal, not of nothing removed


def test_a_saved_predictor_of_another_matcher_is_refused(tmp_path, sample):
    predictor = smr.train(sample["train"], settings=SMALL)
    smr.save_predictor(predictor, tmp_path / "p.h5", matcher="seqslam")
    loaded = smr.load_predictor(tmp_path / "p.h5")
    with pytest.raises(ValueError, match="trained on attributes of .*monotone"):
        smr.metrics(sample["val_distances"], 4, matcher="monotone", predictor=loaded)
    smr.metrics(sample["val_distances"], 4, matcher="seqslam", predictor=loaded)  # its own matcher: accepted


class Oracle:
    """A predictor that knows the labels: it puts each query in its true class (attribute A1 holds it)."""

    classes_ = np.arange(4)

    def predict_proba(self, features: np.ndarray) -> np.ndarray:
        return np.eye(4)[features[:, 0].astype(int)]


def test_evaluate_a_removal_of_exactly_the_wrong_matches():
    correct = np.array([False, True, True, True])
    labels = np.where(correct, 0, 3)
    attributes = np.zeros((4, 1, 4))
    attributes[:, 0, 0] = labels
    features = make_features(correct, correct[:, None], attributes=attributes, labels=labels)
    found = smr.evaluate(features, [Oracle()], trust_levels=())
    assert found.removed == 1 and found.f1_macro == 1.0
    assert found.recall_at_1_sequence == 0.75
    # paper mode, by hand: recall over the 3 correct matches, one point per threshold at the distances 0.1 .. 0.4
    # (precision 0 where nothing is accepted), areas by the trapezoid rule up to the max recall 1:
    #   VPR+SM      (0, 0) (1/3, 1/2) (2/3, 2/3) (1, 3/4): AUC 1/12 + 7/36 + 17/72 = 37/72, AOC 35/72
    #   with removal (0, 0) (1/3, 1) (2/3, 1) (1, 1):       AUC 1/6 + 1/3 + 1/3 = 5/6,     AOC 1/6
    reduction = found.modes["paper"].reduction
    assert reduction.max_recall == 1.0
    assert reduction.aoc_vpr_sm == pytest.approx(35 / 72) and reduction.aoc_vpr_sm_pred == pytest.approx(1 / 6)
    assert reduction.reduction_pct == pytest.approx(100 * (35 / 72 - 1 / 6) / (35 / 72))


def test_evaluate_a_trained_predictor(sample):
    predictor = smr.train(sample["train"], settings=SMALL)
    found = smr.evaluate(sample["val"], predictor, trust_levels=())
    predicted = predictor.predict(sample["val"].attributes[:, 0, :])
    assert found.f1_macro == pytest.approx(f1_score(sample["val"].labels, predicted, average="macro"))
    assert found.removed == int(np.isin(predicted, (1, 3)).sum())
    assert found.recall_at_1_sequence == pytest.approx(sample["val"].sequence_correct.mean())


def test_scores_against_naive_rules(sample):
    features = sample["val"]
    found = smr.scores(features)
    assert np.array_equal(found["distance"], -features.sequence_distance)
    assert np.array_equal(found["oracle"], features.sequence_correct.astype(float))
    # uniqueness (r_window 10): the smallest score outside |r - r*| <= 5 over the match's, from the whole rows
    rows = smr.match(sample["val_distances"], 4).scores
    references = np.arange(rows.shape[1])
    expected = []
    for row in rows:
        best = int(np.argmin(row))
        outside = row[np.abs(references - best) > 5]
        expected.append(outside.min() / row[best])
    np.testing.assert_allclose(found["uniqueness"], expected, rtol=1e-12)


def test_baselines_detection_is_average_precision(sample):
    features = sample["val"]
    found = smr.baselines(features)
    wrong = ~features.sequence_correct
    confidence = smr.scores(features)["uniqueness"]
    assert found.detection["uniqueness"].average_precision == pytest.approx(
        average_precision_score(wrong, -confidence))
    assert found.n_wrong == int(wrong.sum()) and found.removal is None
    predictor = smr.train(sample["train"], settings=SMALL)
    budget = int((~smr.predict(predictor, features).kept).sum())
    with_predictor = smr.baselines(features, predictors=[predictor])
    assert with_predictor.removal is not None and with_predictor.removal[0].budget == budget


def test_plain_is_json_data():
    found = smr.plain(smr.metrics(D, 2, tolerance=0))
    assert json.loads(json.dumps(found)) == found
    assert found["modes"]["standard"]["single"]["recall_at"]["1"] == 0.5


# --- errors -------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("call", "message"), [
    (lambda: smr.metrics(np.ones((3, 4)), 2), "ground_truth: the matrix is 3 x 4"),
    (lambda: smr.metrics(D, 2, ground_truth=np.ones((2, 3), bool)), "ground_truth: "),
    (lambda: smr.metrics(D, 2, tolerance=-1), "tolerance: a number of frames >= 0"),
    (lambda: smr.match(D, 2, matcher="seqslm"), "unknown sequence matcher 'seqslm'"),
    (lambda: smr.match(D, 2, settings={"velocity": [1.0]}), "settings.velocity: unexpected setting"),
    (lambda: smr.attributes(D, 2, candidates=-1), "candidates: a number of candidates per query >= 0"),
    (lambda: smr.train([]), "features: give the training split's features"),
    (lambda: smr.train(make_features([True] * 4, np.ones((4, 1), bool)), settings={"hidden": [3]}),
     "settings.hidden: unexpected setting"),
    (lambda: smr.scores(smr.attributes(D, 2, candidates=0)), "features holds no candidates"),
    (lambda: smr.evaluate(make_features([True] * 4, np.ones((4, 1), bool)), [Oracle()], modes=["strict"]),
     "modes: unknown metric modes"),
    (lambda: smr.sample_distances("nope"), "has no split 'nope'; it has train, val, test"),
    (lambda: smr.sample_distances("val", "netvlad"), "backend: 'netvlad' needs a checkpoint"),
    (lambda: smr.sample_distances("val", frames=0), "frames: a number of frames >= 1"),
])
def test_bad_arguments_are_named(call, message):
    with pytest.raises(ValueError, match=None) as error:
        call()
    assert message in str(error.value)


def test_a_missing_key_names_the_option(tmp_path):
    np.savez(tmp_path / "two.npz", a=D, b=D)
    with pytest.raises(ValueError) as error:
        smr.read_distances(tmp_path / "two.npz")
    assert str(error.value).endswith("choose a references x queries matrix with key NAME")


# --- the public surface ----------------------------------------------------------------------------------------


def test_every_public_name_exists_and_is_documented():
    assert smr.__all__ and len(set(smr.__all__)) == len(smr.__all__)
    for name in smr.__all__:
        item = getattr(smr, name)
        assert callable(item) and item.__module__ == smr.__name__
        doc = inspect.getdoc(item) or ""
        returns_nothing = inspect.signature(item).return_annotation in (None, "None")
        takes_nothing = not inspect.signature(item).parameters
        assert ("Args:" in doc or takes_nothing) and ("Returns:" in doc or returns_nothing), name
        for parameter in inspect.signature(item).parameters:
            assert f"{parameter}:" in doc, f"{name}: {parameter} is not documented"


def _our_classes(hint, found):
    """The classes of this package in a type hint, and in the fields of those that are dataclasses (the records
    inside a record), into ``found``."""
    if typing.get_origin(hint) is not None or isinstance(hint, types.UnionType):
        for argument in typing.get_args(hint):
            _our_classes(argument, found)
        return
    if not isinstance(hint, type) or not hint.__module__.startswith("vpr_smr.") or hint in found:
        return
    found.add(hint)
    if dataclasses.is_dataclass(hint):
        for field_hint in typing.get_type_hints(hint).values():
            _our_classes(field_hint, found)


def test_every_record_the_api_takes_or_returns_is_in_records():
    found = set()
    for name in smr.__all__:
        for hint in typing.get_type_hints(getattr(smr, name)).values():
            _our_classes(hint, found)
    exported = {getattr(records, name) for name in records.__all__}
    assert records.QueryFeatures in found and records.MatcherMetrics in found  # returned, and inside a returned one
    assert {cls.__qualname__ for cls in found - exported} == set(), "add them to vpr_smr/records.py"
    assert len(set(records.__all__)) == len(records.__all__)


# --- the workflow's stages from Python -------------------------------------------------------------------------


def test_run_stage_writes_what_the_command_writes(tmp_path):
    np.save(tmp_path / "d.npy", D)
    cli(["attributes", "--distances", str(tmp_path / "d.npy"), "--seq-len", "2", "--tolerance", "0",
         "--out", str(tmp_path / "cli.csv")])
    assert "attributes" in smr.stage_commands()
    found = smr.run_stage("attributes", distances=tmp_path / "d.npy", seq_len=2, truth={"tolerance": 0},
                          out=tmp_path / "api.csv")
    assert list(found.labels) == [0, 2]  # by hand, as in test_attributes_labels_by_hand
    assert (tmp_path / "api.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    # the group as its record, the matcher as its setting: the same file
    again = smr.run_stage("attributes", distances=str(tmp_path / "d.npy"), seq_len=2, truth=TruthSource(tolerance=0),
                          matcher={"matcher": "seqslam", "velocities": [1.0]}, out=str(tmp_path / "again.csv"))
    assert (tmp_path / "again.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    assert list(again.sequence_match) == [1, 2]


@pytest.mark.parametrize(("call", "message"), [
    (lambda: smr.run_stage("atributes"), "command: no stage 'atributes'; the stages: descriptors"),
    (lambda: smr.run_stage("attributes", seq_len=2, out="a.csv"), "attributes.distances: the distance matrix"),
    (lambda: smr.run_stage("attributes", distances="d.npy", seq_len=2, out="a.csv", tolerance=0),
     "attributes.tolerance: unexpected setting"),
])
def test_run_stage_names_what_is_wrong(call, message):
    with pytest.raises(ValueError) as raised:
        call()
    assert message in str(raised.value)


# --- the package's face ----------------------------------------------------------------------------------------


def python(code):
    """``code`` run by this Python outside the checkout (the installed package, as a notebook imports it)."""
    result = subprocess.run([sys.executable, "-c", code], cwd=REPO.parent, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout


def test_import_vpr_smr_gives_the_version_and_the_api_on_first_use():
    version = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    printed = python("import sys, vpr_smr; print(vpr_smr.__version__); print('vpr_smr.api' in sys.modules); "
                     "import vpr_smr.api; print(vpr_smr.api.metrics.__module__); "
                     "print(vpr_smr.records.QueryFeatures.__module__)")
    assert printed.split() == [version, "False", "vpr_smr.api", "vpr_smr.eval.matching.attributes"]


def test_the_old_import_still_works_and_warns_once_naming_the_new_one():
    printed = python("import warnings\n"
                     "with warnings.catch_warnings(record=True) as caught:\n"
                     "    warnings.simplefilter('always')\n"
                     "    from vpr_smr.pipeline import api as old\n"
                     "    import vpr_smr.pipeline.api\n"
                     "import vpr_smr.api as new\n"
                     "print(len(caught), caught[0].category.__name__, caught[0].filename, caught[0].lineno)\n"
                     "print(old.__all__ == new.__all__\n"
                     "      and all(getattr(old, name) is getattr(new, name) for name in new.__all__))\n"
                     "print(caught[0].message)\n")
    first, same, message = printed.splitlines()
    assert first.split() == ["1", "DeprecationWarning", "<string>", "4"]  # once, at the importing line
    assert same == "True"
    assert "write `from vpr_smr import api as smr`" in message
