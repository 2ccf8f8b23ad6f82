"""The matcher ``monotone`` (method §14): Viterbi over band transitions on the column-normalised matrix, checked
against a plain dynamic programme written here from the definition (per query, per reference, per step loops), a
case worked out by hand, block-wise = whole split, and the messages of bad settings and too short splits."""

import numpy as np
import pytest

from vpr_smr.eval.matching.features import match_blocks, split_features
from vpr_smr.eval.matching.matchers import MatcherSpec, matcher_class, monotone
from vpr_smr.eval.matching.matchers.monotone import Monotone, MonotoneSettings


def naive_scores(d, seq_len, max_step, step_penalty):
    """s_a[r] of every query a >= L - 1 as the definition states it, one number at a time in Python floats."""
    n_ref, n_query = d.shape
    dn = [[0.0] * n_query for _ in range(n_ref)]
    for q in range(n_query):
        top = max(float(d[r, q]) for r in range(n_ref))
        top = 1.0 if top == 0 else top
        for r in range(n_ref):
            dn[r][q] = float(d[r, q]) / top
    out = []
    for a in range(seq_len - 1, n_query):
        start = a - seq_len + 1
        cost = [dn[r][start] for r in range(n_ref)]
        for k in range(1, seq_len):
            new = []
            for r in range(n_ref):
                best = None
                for t in range(max_step + 1):
                    if r - t >= 0:
                        value = cost[r - t] + step_penalty * abs(t - 1)
                        best = value if best is None or value < best else best
                new.append(best + dn[r][start + k])
            cost = new
        out.append(cost)
    return np.array(out)


def whole(d, seq_len, **values):
    matcher = MatcherSpec.of("monotone", values).build(seq_len)
    found = [block for block, _, _ in match_blocks(matcher, d, block_queries=10**6)]
    assert len(found) == 1
    return found[0]


@pytest.mark.parametrize(("seq_len", "max_step", "penalty"),
                         [(2, 1, 0.0), (3, 2, 0.1), (4, 2, 0.0), (5, 3, 0.37), (8, 2, 0.1), (6, 4, 1.5)])
def test_scores_equal_a_naive_dynamic_programme_bit_for_bit(seq_len, max_step, penalty):
    rng = np.random.default_rng(seq_len * 100 + max_step)
    d = rng.random((13, 17)) * rng.random(17)  # columns of different scales: the normalisation matters
    d[:, 3] = 0.0  # a zero column divides by 1
    found = whole(d, seq_len, max_step=max_step, step_penalty=penalty)
    expected = naive_scores(d, seq_len, max_step, penalty)
    assert np.array_equal(found.queries, np.arange(seq_len - 1, 17))
    assert found.scores.dtype == np.float64
    assert np.array_equal(found.scores, expected)  # bit for bit
    assert np.array_equal(found.match, [int(np.flatnonzero(row == row.min())[0]) for row in expected])
    assert found.native is None and Monotone.native_scorer == "uniqueness"


def test_a_float32_matrix_is_divided_in_float64():
    d = np.random.default_rng(5).random((9, 11)).astype(np.float32)
    assert np.array_equal(whole(d, 4).scores, naive_scores(d, 4, 2, 0.1))


def test_a_hand_worked_case():
    # Column maxima are 1 (each column holds a 1), so Dn = D. L = 3, max_step 2, step_penalty 0.5:
    #   D (rows r = 0..3, columns q = 0..2)    query a = 2 reads columns 0, 1, 2
    #   r0: 0  1  1                            C_0 = [0, 1, 1, 1]
    #   r1: 1  1  0                            C_1[r] = min_t (C_0[r-t] + 0.5|t-1|) + D[r, 1]:
    #   r2: 1  1  1                              r0: t=0 0+0.5=0.5            -> 0.5 + 1 = 1.5
    #   r3: 1  0  1                              r1: t=0 1.5, t=1 0           -> 0 + 1 = 1
    #                                            r2: t=0 1.5, t=1 1, t=2 0.5  -> 0.5 + 1 = 1.5
    #                                            r3: t=0 1.5, t=1 1, t=2 1.5  -> 1 + 0 = 1
    #   C_2[r] = min_t (C_1[r-t] + 0.5|t-1|) + D[r, 2]:
    #     r0: 1.5+0.5=2 -> 2 + 1 = 3;  r1: min(1.5, 1.5) -> 1.5 + 0 = 1.5
    #     r2: min(2, 1, 2) = 1 -> 1 + 1 = 2;  r3: min(1.5, 1.5, 1.5) -> 1.5 + 1 = 2.5
    # The match is r = 1 (the path 0 -> 0 -> 1: a stay, then a step of 1, cost 0.5); the straight diagonal
    # 0 -> 1 -> 2 would end at r = 2 with 0 + 1 + 1 = 2. Without the penalty the stay is free:
    #   C_1 = [0+1, 0+1, 0+1, 1+0] = [1, 1, 1, 1], C_2 = [1+1, 1+0, 1+1, 1+1] = [2, 1, 2, 2].
    d = np.array([[0, 1, 1], [1, 1, 0], [1, 1, 1], [1, 0, 1]], dtype=np.float64)
    found = whole(d, 3, max_step=2, step_penalty=0.5)
    assert found.scores.tolist() == [[3.0, 1.5, 2.0, 2.5]] and found.match.tolist() == [1]
    assert whole(d, 3, max_step=2, step_penalty=0.0).scores.tolist() == [[2.0, 1.0, 2.0, 2.0]]


@pytest.mark.parametrize("block_queries", [1, 3, None])
@pytest.mark.parametrize("chunk_values", [monotone.CHUNK_VALUES, 100])  # 100: a block in passes of 2 queries
def test_block_wise_equals_the_whole_split(block_queries, chunk_values, monkeypatch):
    monkeypatch.setattr(monotone, "CHUNK_VALUES", chunk_values)
    rng = np.random.default_rng(7)
    d = rng.random((40, 37))
    expected = naive_scores(d, 5, 2, 0.1)
    matcher = MatcherSpec.of("monotone").build(5)
    blocks = list(match_blocks(matcher, d, block_queries=block_queries or 10**6))
    assert len(blocks) == (33 if block_queries == 1 else 11 if block_queries == 3 else 1)
    assert np.array_equal(np.concatenate([b.scores for b, _, _ in blocks]), expected)
    assert np.array_equal(np.concatenate([b.queries for b, _, _ in blocks]), np.arange(4, 37))
    features = split_features(matcher, d, n_ranks=4, block_queries=block_queries, n_candidates=3)
    rows = np.arange(len(expected))
    match = expected.argmin(axis=1)
    assert np.array_equal(features["queries"], np.arange(4, 37))
    assert np.array_equal(features["sequence_match"], match)
    assert np.array_equal(features["sequence_distance"], expected[rows, match])
    assert np.array_equal(features["sequence_max"], expected.max(axis=1))
    order = np.argsort(expected, axis=1, kind="stable")[:, :3]
    assert np.array_equal(features["sequence_candidate_references"], order)
    assert np.array_equal(features["sequence_candidates"], np.take_along_axis(expected, order, axis=1))


def test_the_registry_and_the_defaults():
    assert matcher_class("monotone") is Monotone
    assert MatcherSpec.of("monotone").values == {"max_step": 2, "step_penalty": 0.1}
    assert MonotoneSettings() == MonotoneSettings(2, 0.1)


@pytest.mark.parametrize(("values", "message"), [
    ({"max_step": 0}, r"sequence_matching\.max_step: the largest step of a path, in reference frames per query "
                      r"frame \(steps 0 \.\. max_step\); must be >= 1, got 0"),
    ({"max_step": 1.5}, r"sequence_matching\.max_step: expected an integer, got 1\.5"),
    ({"step_penalty": -0.1}, r"sequence_matching\.step_penalty: the cost of a step t, step_penalty \* \|t - 1\| "
                             r"\(0: every step is free\); must be >= 0, got -0\.1"),
    ({"max_steps": 3}, r"sequence_matching\.max_steps: unexpected setting 'max_steps' \(did you mean 'max_step'\?\)"),
])
def test_bad_settings_are_refused_naming_the_setting(values, message):
    with pytest.raises(ValueError, match=message):
        MatcherSpec.of("monotone", values)


def test_a_split_shorter_than_the_sequence_is_refused_with_the_fix():
    matcher = MatcherSpec.of("monotone").build(8)
    with pytest.raises(ValueError, match=r"test\.h5 of shape 20x7 is too short for the matcher monotone at sequence "
                                         r"length 8: it needs at least 1 reference and 8 query columns$"):
        matcher.check((20, 7), "test.h5")
    matcher.check((20, 8), "test.h5")
    with pytest.raises(ValueError, match="must be 2-D"):
        matcher.check((20,), "test.h5")


def test_nan_and_inf_are_refused_counted_over_the_whole_matrix():
    d = np.random.default_rng(0).random((10, 12))
    d[4, 7], d[2, 9] = np.nan, np.inf  # the NaN lies in a later block than the first query's; the inf later still
    matcher = MatcherSpec.of("monotone").build(3)
    with pytest.raises(ValueError, match=r"distance matrix has 2 non-finite values \(1 NaN, 1 inf\); the first is "
                                         r"NaN at row 4 \(reference\), column 7 \(query\)"):
        list(match_blocks(matcher, d, block_queries=2))
