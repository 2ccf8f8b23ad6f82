"""Sequence recall@N ranks the matcher's match first, then the other references by the matcher's score (method §14).

A filter's match need not be its lowest score (the Bayes filter's is the belief's weighted mean near its peak), so
recall@1 must be the share of correct matches that the per-query table and the attributes' labels give, for every
matcher. The matrix is HOG on the first 200 frames of the shipped sample's test split, which no other test uses.
"""

import csv
import json

import numpy as np
import pytest

from vpr_smr import api as smr
from vpr_smr.core.constants import RECALL_AT
from vpr_smr.eval.scoring.vpr_metrics import NOT_RETRIEVED, _best_correct_rank
from vpr_smr.pipeline.cli import main

SEQ_LEN, TOLERANCE = 4, 2
# the published ProbFiltersVPR window: its match is not its lowest score for most queries of this matrix
MATCHERS = {"seqslam": {}, "openseqslam": {}, "monotone": {},
            "bayes_filter": {"window_lo": -2, "window_hi": 10}}


def test_match_first_by_hand():
    # one query, four references: scores 0.1, 0.5, 0.2, 0.9; the matcher's match is reference 3
    values = np.array([[0.1], [0.5], [0.2], [0.9]])
    match = np.array([3])
    for correct_row, by_score, match_first in ((1, 2, 3), (0, 0, 1), (3, 3, 0)):
        correct = np.zeros((4, 1), dtype=bool)
        correct[correct_row] = True
        # by score: 0 (0.1), 2 (0.2), 1 (0.5), 3 (0.9); match first: 3, then 0, 2, 1
        assert _best_correct_rank(values, correct)[0] == by_score
        assert _best_correct_rank(values, correct, match)[0] == match_first


def test_a_match_no_path_reaches_still_counts():
    # the match's own score is +inf (no belief reached it): it is the matcher's answer all the same
    values = np.array([[0.3], [np.inf], [0.1]])
    correct = np.array([[False], [True], [False]])
    assert _best_correct_rank(values, correct)[0] == NOT_RETRIEVED
    assert _best_correct_rank(values, correct, np.array([1]))[0] == 0


@pytest.fixture(scope="module")
def matrix(tmp_path_factory):
    path = tmp_path_factory.mktemp("recall") / "hog_test_0_200.npy"
    np.save(path, smr.sample_distances("test", "hog", frames=200))
    return path


def _options(name):
    options = ["--matcher", name]
    for key, value in MATCHERS[name].items():
        options += [f"--{key.replace('_', '-')}", str(value)]
    return options


def _naive_recall(distances, name):
    """Recall@N by a loop: the match, then the other references by score (stable), hit when one of the first N
    is within the tolerance."""
    found = smr.match(distances, SEQ_LEN, matcher=name, settings=MATCHERS[name])
    # the queries with attributes (a window of L frames ending at them): a centred matcher evaluates earlier ones too
    windowed = found.queries >= SEQ_LEN - 1
    found = type(found)(found.queries[windowed], found.scores[windowed], found.match[windowed], None)
    hits = {n: 0 for n in RECALL_AT}
    for query, scores, match in zip(found.queries, found.scores, found.match, strict=True):
        others = [r for r in np.argsort(scores, kind="stable") if r != match and np.isfinite(scores[r])]
        ranked = [int(match), *others]
        for n in RECALL_AT:
            hits[n] += any(abs(r - query) <= TOLERANCE for r in ranked[:n])
    return {n: hits[n] / len(found.queries) for n in RECALL_AT}, found


@pytest.mark.parametrize("name", MATCHERS)
def test_sequence_recall_at_1_is_the_share_of_correct_matches(matrix, tmp_path, name):
    out, table, labels = tmp_path / "m.json", tmp_path / "q.csv", tmp_path / "a.csv"
    common = ["--distances", str(matrix), "--seq-len", str(SEQ_LEN), *_options(name)]
    assert main(["metrics", *common, "--no-baselines", "--queries", str(table), "--out", str(out)]) == 0
    assert main(["attributes", *common, "--out", str(labels)]) == 0
    correct_in_table = [int(r["sequence_correct"]) for r in csv.DictReader(open(table))]
    # label 0 or 2: the sequence match is correct (method §6)
    correct_by_label = [int(r["label"]) in (0, 2) for r in csv.DictReader(open(labels))]
    assert correct_in_table == [int(c) for c in correct_by_label]
    naive, found = _naive_recall(np.load(matrix), name)
    share = sum(correct_in_table) / len(correct_in_table)
    assert naive[1] == pytest.approx(share, abs=1e-12)
    modes = json.load(open(out))["splits"]["all"]["modes"]
    for mode in ("paper", "standard"):
        sequence = modes[mode]["sequence"]
        assert sequence["n_queries"] == len(correct_in_table) == len(found.queries)
        assert sequence["recall_at"]["1"] == pytest.approx(share, abs=1e-12)
        for n in RECALL_AT:
            assert sequence["recall_at"][str(n)] == pytest.approx(naive[n], abs=1e-12)
    if name == "bayes_filter":
        # the case that made the difference: most of the filter's matches are not its lowest score here
        lowest = np.argmin(found.scores, axis=1)
        assert np.count_nonzero(lowest != found.match) > len(found.match) / 2
