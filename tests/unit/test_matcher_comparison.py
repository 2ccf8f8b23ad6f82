"""The experiment ``matchers`` (method §14): the compared matchers and their tags, the queries every matcher
evaluates, the validation warning, the table's rows and the section's sentence, each against values worked out by
hand."""

import hashlib
from dataclasses import replace

import numpy as np
import pytest
from helpers import make_features
from report_runs import matchers_records
from row_records import records

from vpr_smr.core.records import load, save
from vpr_smr.eval.matching.matchers import MATCHERS, MatcherSpec
from vpr_smr.eval.report.rows import cells
from vpr_smr.eval.report.tables.matchers import MatchersRow, comparison_sentence, matcher_rows, matcher_sentences
from vpr_smr.eval.scoring.matcher_comparison import (
    MatcherComparison,
    experiment_matchers,
    far_below,
    matcher_tag,
    restricted,
    shared_queries,
    validation_warning,
)

# --- the compared matchers ----------------------------------------------------------------------------------------


def test_the_default_is_every_built_in_matcher_at_its_defaults():
    assert experiment_matchers(None) == [MatcherSpec.of(name) for name in MATCHERS]


def test_a_matcher_at_its_defaults_is_tagged_by_its_name_else_by_its_settings_digest():
    assert matcher_tag(MatcherSpec.of("seqslam")) == "seqslam"
    assert matcher_tag(MatcherSpec.of("seqslam", {"velocities": [1]})) == "seqslam"  # 1 and 1.0: the defaults
    # the canonical settings text, spelt out: '{"velocities": [0.5, 1.0]}'
    digest = hashlib.sha256(b'{"velocities": [0.5, 1.0]}').hexdigest()[:8]
    assert matcher_tag(MatcherSpec.of("seqslam", {"velocities": [0.5, 1]})) == f"seqslam-{digest}"


def test_bad_lists_of_matchers_are_refused_naming_the_setting():
    with pytest.raises(ValueError, match=r"matchers lists no matcher: give at least one, or switch the experiment off"):
        experiment_matchers([])
    with pytest.raises(ValueError, match=r"matchers lists the matcher seqslam twice with the same settings"):
        experiment_matchers([{"matcher": "seqslam"}, {"matcher": "seqslam", "velocities": [1.0]}])
    with pytest.raises(ValueError, match=r"matchers\[1\]: .* is not of the form \{matcher: NAME"):
        experiment_matchers([{"matcher": "seqslam"}, {"velocities": [1.0]}])
    with pytest.raises(ValueError, match=r"matchers\[0\].matcher: unknown sequence matcher 'seqslum'"):
        experiment_matchers([{"matcher": "seqslum"}])


# --- the shared queries -------------------------------------------------------------------------------------------


def _features(queries, correct, distances):
    n = len(queries)
    return make_features(correct, np.ones((n, 1), bool), queries=np.asarray(queries),
                         sequence_distance=np.asarray(distances, float), sequence_match=np.arange(n) + 10,
                         sequence_min=float(min(distances)), sequence_max=9.0, all_single_correct=np.ones(12, bool))


def test_the_shared_queries_are_those_every_matcher_evaluates_and_each_is_cut_to_them():
    # a trailing window (queries 3..8), a centred one (2..6) and a filter (every query 3..9 it has a window for)
    trailing = _features([3, 4, 5, 6, 7, 8], [1, 0, 1, 1, 0, 1], [0.6, 0.1, 0.5, 0.4, 0.3, 0.2])
    centred = _features([2, 3, 4, 5, 6], [0, 1, 1, 0, 1], [0.1, 0.8, 0.7, 0.6, 0.5])
    filtered = _features([3, 4, 5, 6, 7, 8, 9], [1] * 7, [1.0] * 7)
    shared = shared_queries([trailing, centred, filtered])
    assert shared.tolist() == [3, 4, 5, 6]
    cut = restricted(trailing, shared)
    assert cut.queries.tolist() == [3, 4, 5, 6]
    assert cut.sequence_correct.tolist() == [True, False, True, True]
    assert cut.sequence_match.tolist() == [10, 11, 12, 13]  # rows 0..3 of trailing
    assert cut.attributes.shape == (4, 1, 4) and cut.rank_correct.shape == (4, 1)
    assert cut.sequence_min == 0.1  # the smallest kept match's (query 4)
    assert cut.sequence_max == 9.0 and len(cut.all_single_correct) == 12  # the split's, kept
    assert restricted(centred, shared).sequence_min == 0.5  # query 2's 0.1 is left out: query 6's
    with pytest.raises(ValueError, match="query 2 is not among the features' evaluated queries"):
        restricted(trailing, np.array([2, 3]))


def test_the_validation_warning_fires_strictly_under_half_the_fixed_matchers_recall():
    assert far_below(0.29, 0.6) and not far_below(0.30, 0.6) and not far_below(0.9, 0.6)
    assert validation_warning("bayes_filter", "sad", 0.30, 0.6) is None
    assert validation_warning("bayes_filter", "sad", None, 0.6) is None
    assert validation_warning("bayes_filter", "sad", 0.05, 0.6) == (
        "bayes_filter on sad: validation recall@1 0.050 is under 0.5 of the fixed matcher's (0.600); its settings "
        "may not fit the traverses (a filter's transition window must fit their speed ratio, docs/method.md)")


# --- the table and its sentence -----------------------------------------------------------------------------------


def test_the_rows_follow_the_record_and_the_sentence_counts_the_intervals(tmp_path):
    results = matchers_records()
    save(tmp_path / "L4.json", results[0])
    assert load(tmp_path / "L4.json", MatcherComparison) == results[0]  # the record's codec, both ways
    records = matcher_rows(results)
    rows = [cells(row) for row in records]
    assert [(r["method"], r["matcher"]) for r in rows] == [
        ("sad", "seqslam"), ("sad", "bayes_filter"), ("hog", "seqslam"), ("hog", "bayes_filter")]
    first = rows[0]
    assert (first["n_queries"], first["n_evaluated"], first["reduction_pct"], first["reduction_pct_ci_low"],
            first["reduction_pct_mean"], first["best_scorer"], first["best_scorer_reduction_pct"],
            first["native_reduction_pct"], first["native_minus_predictor_ci_high"], first["ap_predictor"],
            first["ap_native"], first["fixed_validation_recall_at_1"], first["warning"]) == (
        25, 30, 20.0, 5.0, 19.0, "distance", 10.0, 10.0, -1.0, 0.6, 0.4, 0.6, "")
    assert [r["warning"] for r in rows] == ["", "", "", "validation R@1 under 0.5 of the fixed matcher's"]
    # reduced: seqslam on sad and hog (lows 5, 2); raised: bayes_filter on hog (high -1); beats: seqslam on sad
    # (native - predictor high -1); seqslam on hog (high 4) and bayes_filter (3, none) do not
    assert comparison_sentence(records) == (
        "On d (L = 4, paper mode, the 25 queries every matcher evaluates), SMR reduces the AOC for 2 of 4 "
        "matcher-method pairs (the seed-0 predictor's reduction, its 95 % interval above 0); it raises it for 1 "
        "(the interval below 0); it beats the matcher's own confidence for 1 (the paired 95 % interval of the "
        "native confidence's reduction minus the predictor's, removing as many matches, below 0).")
    sentences = matcher_sentences(records)
    assert sentences[1] == (
        "Warning: bayes_filter on hog has a validation recall@1 of 0.200, under 0.5 of the fixed matcher's (0.600): "
        "its settings may not fit the traverses (a filter's transition window must fit their speed ratio).")
    assert len(sentences) == 2


# --- the comparison on small matrices -----------------------------------------------------------------------------


def test_each_matcher_is_scored_on_the_shared_queries_with_its_own_predictors():
    from sklearn.metrics import average_precision_score

    from vpr_smr.eval.matching.attributes import query_features
    from vpr_smr.eval.predictor.estimator import SMRPredictor
    from vpr_smr.eval.scoring.matcher_comparison import compare
    from vpr_smr.eval.scoring.scorers import DEFAULT_SETTINGS

    rng = np.random.default_rng(3)
    matrix = rng.random((40, 40)) + 0.6 * (1 - np.eye(40))  # a noisy diagonal: some matches right, some wrong
    seq_len, tolerance = 3, 1
    whole = query_features(matrix, seq_len, tolerance, n_candidates=DEFAULT_SETTINGS.candidates)
    assert whole.queries.tolist() == list(range(2, 40))
    # a second matcher that evaluates queries 5..39 only (as a centred window leaves some out): the same matches
    later = restricted(whole, np.arange(5, 40))
    table = {"a": {"m": whole}, "b": {"m": later}}
    fitted = [SMRPredictor(hidden_layer_sizes=(8,), max_iter=30, random_state=s).fit(
        whole.attributes[:, 0], whole.labels) for s in (0, 1)]
    # validation: matcher b matches nothing right there, the fixed matcher 3 of 4 of the shared queries
    wrong = replace(later, sequence_correct=np.zeros(35, bool))
    fixed = replace(whole, sequence_correct=np.arange(38) % 4 != 0)  # wrong at queries 2, 6, 10, ..., 38
    n, n_val, scores, fixed_recall, warnings = compare(
        table, {"a": fitted, "b": fitted}, {"m": np.arange(40.0)}, DEFAULT_SETTINGS, ("paper",),
        {"a": {"m": whole}, "b": {"m": wrong}}, {"m": fixed})
    assert n == 35 and n_val == 35  # queries 5..39
    assert scores["a"]["m"].n_evaluated == 38 and scores["b"]["m"].n_evaluated == 35
    # recall@1 after sequence matching, by hand: the match within 1 frame of the query, over queries 5..39
    by_hand = np.mean([abs(int(r) - int(q)) <= tolerance for q, r in zip(whole.queries, whole.sequence_match,
                                                                           strict=True) if q >= 5])
    for tag in ("a", "b"):
        assert scores[tag]["m"].modes["paper"].recall_at_1_sequence == pytest.approx(by_hand, abs=1e-15)
    # the seed-0 predictor's detection of the wrong matches, as scikit-learn ranks it, on the same queries
    rows = whole.queries >= 5
    probabilities = fitted[0].predict_proba(whole.attributes[rows, 0])
    classes = list(fitted[0].classes_)
    confidence = 1 - sum(probabilities[:, classes.index(c)] for c in (1, 3) if c in classes)
    expected = average_precision_score(~whole.sequence_correct[rows], -confidence)
    assert scores["a"]["m"].detection_predictor.average_precision == pytest.approx(expected, rel=1e-12)
    # the fixed matcher on queries 5..39: wrong at 6, 10, ..., 38 (9 queries), right at the other 26
    assert fixed_recall == {"m": pytest.approx(26 / 35, abs=1e-15)}
    assert scores["b"]["m"].validation_recall_at_1 == 0.0
    assert [w.split(":")[0] for w in warnings] == ["b on m"]
    # validation splits that share no query: no recall at all (not a recall of 0), so no warning
    early = restricted(whole, np.arange(2, 5))  # queries 2..4, none of which b evaluates
    _, n_val, scores, fixed_recall, warnings = compare(
        table, {"a": fitted, "b": fitted}, {"m": np.arange(40.0)}, DEFAULT_SETTINGS, ("paper",),
        {"a": {"m": early}, "b": {"m": wrong}}, {"m": fixed})
    assert n_val == 0 and fixed_recall == {} and warnings == ()
    assert scores["a"]["m"].validation_recall_at_1 is None and scores["b"]["m"].validation_recall_at_1 is None


def test_a_degenerate_removal_counts_neither_way_whatever_its_interval():
    # a removal that kept no correct match has no direction, even with an interval above 0; a pair whose interval
    # holds 0 or is missing counts neither way; beats: the paired interval wholly below 0 only
    base = {"dataset": "d", "seq_len": 4, "mode": "paper", "n_queries": 30, "native_minus_predictor_ci_low": None,
            "native_minus_predictor_ci_high": None}
    rows = [{**base, "outcome": "kept_none_correct", "reduction_pct_ci_low": 5.0, "reduction_pct_ci_high": 9.0},
            {**base, "outcome": "improved", "reduction_pct_ci_low": -5.0, "reduction_pct_ci_high": 9.0},
            {**base, "outcome": "improved", "reduction_pct_ci_low": None, "reduction_pct_ci_high": None,
             "native_minus_predictor_ci_low": -3.0, "native_minus_predictor_ci_high": 2.0},
            {**base, "outcome": "worse", "reduction_pct_ci_low": 1.0, "reduction_pct_ci_high": 2.0,
             "native_minus_predictor_ci_low": -3.0, "native_minus_predictor_ci_high": -2.0}]
    assert comparison_sentence(records(MatchersRow, rows)) == (
        "On d (L = 4, paper mode, the 30 queries every matcher evaluates), SMR reduces the AOC for 0 of 4 "
        "matcher-method pairs (the seed-0 predictor's reduction, its 95 % interval above 0); it beats the matcher's "
        "own confidence for 1 (the paired 95 % interval of the native confidence's reduction minus the predictor's, "
        "removing as many matches, below 0).")
