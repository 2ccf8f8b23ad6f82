"""``bayes_filter`` (method §14.7): against a naive per-query, per-reference filter written here from the method's
text, a case worked out by hand, block-wise results equal to the whole split's through the shared features code,
and the messages of bad settings and matrices."""

import math

import numpy as np
import pytest

from vpr_smr.eval.matching.features import match_blocks, split_features
from vpr_smr.eval.matching.matchers import MatcherSpec, matcher_class
from vpr_smr.eval.matching.matchers.bayes_filter import BayesFilter, BayesFilterSettings


def build(window=(0, 3), delta=5.0, seq_len=2):
    return MatcherSpec.of("bayes_filter", {"delta": delta, "window_lo": window[0], "window_hi": window[1]}
                          ).build(seq_len)


def linear_quantile(values, p):
    """numpy's default (linear) quantile, by its definition: position p (n - 1) in the sorted values."""
    v = sorted(values)
    pos = p * (len(v) - 1)
    i = math.floor(pos)
    return v[i] if i + 1 >= len(v) else v[i] + (pos - i) * (v[i + 1] - v[i])


def naive(D, delta, lo, hi):
    """The filter as the method states it, one reference at a time: scores -ln b, match, native, per query."""
    R, Q = D.shape
    lam = math.log(delta) / (linear_quantile(D[:, 0], 0.975) - linear_quantile(D[:, 0], 0.025))
    w = (hi - lo) // 2
    out = []
    b = None
    for a in range(Q):
        if b is None:
            b = [math.exp(-lam * D[r, 0]) for r in range(R)]
        else:
            moved = [sum(b[r - j] for j in range(lo, hi) if 0 <= r - j < R) for r in range(R)]
            b = [moved[r] * math.exp(-lam * D[r, a]) for r in range(R)]
        total = sum(b)
        b = [x / total for x in b]
        p = max(range(R), key=lambda r: (b[r], -r))  # argmax, lowest on ties
        around = range(max(p - 2 * w, 0), min(p + 2 * w, R - 1))
        mass = sum(b[r] for r in around)
        match = round(sum(r * b[r] for r in around) / mass)  # Python rounds half to even, as numpy's rint
        out.append(([-math.log(x) if x > 0 else math.inf for x in b], match, mass))
    return out


def run_whole(matcher, D, block_queries=None):
    blocks = [found for found, _, _ in match_blocks(matcher, D, block_queries)]
    return (np.concatenate([f.queries for f in blocks]), np.concatenate([f.scores for f in blocks]),
            np.concatenate([f.match for f in blocks]), np.concatenate([f.native for f in blocks]))


@pytest.mark.parametrize("window", [(0, 3), (-2, 10), (1, 3), (-1, 2), (2, 5), (-3, 0), (0, 2)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_equals_the_naive_filter(window, seed):
    rng = np.random.default_rng(seed)
    R, Q = 30, 12  # a window of steps 2 .. 4 stays on the map for 11 queries (2 x 11 < 30)
    # a path along the diagonal (one reference per query) with noise: the belief has a peak to follow
    D = rng.uniform(0.5, 1.5, (R, Q))
    D[np.arange(Q) % R, np.arange(Q)] -= 0.6
    queries, scores, match, native = run_whole(build(window), D)
    expected = naive(D, 5.0, *window)
    assert queries.tolist() == list(range(Q))
    assert match.tolist() == [m for _, m, _ in expected]
    np.testing.assert_allclose(native, [n for _, _, n in expected], rtol=1e-12)
    np.testing.assert_allclose(scores, [s for s, _, _ in expected], rtol=1e-12, atol=1e-12)


def test_a_case_worked_by_hand():
    # Three references, window [0, 2) (steps 0 and 1; w = 1), delta 5. Column 0 is [0, 1, 2]: its linear 2.5 % and
    # 97.5 % quantiles are 0.05 and 1.95, so lambda = ln 5 / 1.9 and exp(-lambda d) = x^d with x = 5^(-1/1.9).
    # Query 0: b ~ [1, x, x^2]; peak 0, neighbourhood {0 .. min(2, 2) - 1} = {0, 1}; native (1 + x) / Z0;
    #   match rint(x / (1 + x)) = rint(0.30) = 0.
    # Query 1 (column [2, 0, 2], likelihood [x^2, 1, x^2]): moved b' ~ [1, 1 + x, x + x^2], times the likelihood
    #   ~ [x^2, 1 + x, x^3 + x^4]; peak 1, neighbourhood {0, 1}; match rint((1 + x) / (1 + x + x^2)) = rint(0.89) = 1.
    # Query 2 (column [2, 2, 0], likelihood [x^2, x^2, 1]): moved ~ [x^2, 1 + x + x^2, 1 + x + x^3 + x^4], times
    #   the likelihood ~ [x^4, x^2 (1 + x + x^2), 1 + x + x^3 + x^4]; the peak is 2, the last reference, which the
    #   neighbourhood {0 .. min(4, 2) - 1} = {0, 1} leaves out: match rint(x^2 (1+x+x^2) / (x^4 + x^2 (1+x+x^2)))
    #   = rint(0.90) = 1, native (x^4 + x^2 (1 + x + x^2)) / Z2, about 0.18.
    D = np.array([[0.0, 2.0, 2.0], [1.0, 0.0, 2.0], [2.0, 2.0, 0.0]])
    x = 5 ** (-1 / 1.9)
    b0 = np.array([1, x, x * x]) / (1 + x + x * x)
    u1 = np.array([x**2, 1 + x, x**3 + x**4])
    b1 = u1 / u1.sum()
    u2 = np.array([x**4, x**2 * (1 + x + x**2), 1 + x + x**3 + x**4])
    b2 = u2 / u2.sum()
    queries, scores, match, native = run_whole(build((0, 2)), D)
    assert match.tolist() == [0, 1, 1]
    np.testing.assert_allclose(native, [b0[:2].sum(), b1[:2].sum(), b2[:2].sum()], rtol=1e-13)
    np.testing.assert_allclose(scores, -np.log([b0, b1, b2]), rtol=1e-13)
    assert 0.17 < native[2] < 0.19


@pytest.mark.parametrize("window", [(0, 3), (-2, 10)])
def test_block_wise_equals_whole_split(window):
    rng = np.random.default_rng(7)
    D = rng.uniform(0.0, 1.0, (23, 19))
    matcher = build(window, seq_len=3)
    whole = split_features(matcher, D, n_ranks=2, n_candidates=3)
    for block_queries in (1, 3, None):
        assert all(np.array_equal(a, b) for a, b in zip(run_whole(matcher, D, block_queries), run_whole(matcher, D),
                                                         strict=True))
        features = split_features(matcher, D, n_ranks=2, block_queries=block_queries, n_candidates=3)
        assert features.keys() == whole.keys()
        for key, value in whole.items():
            assert np.array_equal(features[key], value), key
    assert whole["queries"].tolist() == list(range(2, 19))  # every query with a window of L = 3 columns


def test_registered_with_its_defaults():
    assert matcher_class("bayes_filter") is BayesFilter
    assert MatcherSpec.of("bayes_filter").record() == BayesFilterSettings(5.0, 0, 3)
    assert BayesFilter.native_scorer is None


@pytest.mark.parametrize(("values", "message"), [
    ({"delta": 1}, "sequence_matching.delta: .* must be > 1, got 1"),
    ({"window_lo": 3, "window_hi": 3}, r"sequence_matching.window_hi: the transition window \[3, 3\) is empty; "
                                       "give window_hi > window_lo"),
    ({"window_lo": 0, "window_hi": 1}, r"sequence_matching.window_hi: the transition window \[0, 1\) moves no frame "
                                       r"\(only step 0\); widen it"),
    ({"window_lo": 1, "window_hi": 2}, r"sequence_matching.window_hi: the transition window \[1, 2\) has one step"),
    ({"window_lo": 0.5}, "sequence_matching.window_lo: expected an integer"),
])
def test_bad_settings(values, message):
    with pytest.raises(ValueError, match=message):
        MatcherSpec.of("bayes_filter", values)


def test_bad_matrices():
    matcher = build()
    with pytest.raises(ValueError, match="distance matrix of shape 5x1 is too small for the matcher bayes_filter: "
                                         "it needs at least 2 references and 2 queries"):
        matcher.check((5, 1))
    flat = np.ones((6, 4))
    flat[:, 1:] = np.arange(6)[:, None]
    with pytest.raises(ValueError, match="query column 0, the split's first, has no spread"):
        run_whole(matcher, flat)
    nan = np.random.default_rng(0).uniform(size=(6, 4))
    nan[2, 3] = np.nan
    with pytest.raises(ValueError, match="1 non-finite value .* row 2 .* column 3"):
        run_whole(matcher, nan)


def test_belief_leaving_the_map_is_an_error():
    # window [2, 4): every step moves the belief 2 or 3 references on; after a few queries it is past the last one
    D = np.random.default_rng(1).uniform(size=(6, 8))
    with pytest.raises(ValueError, match=r"query column \d: the transition window \[2, 4\) moved the whole belief "
                                         r"off the 6 references \(every step moves it on\)"):
        run_whole(build((2, 4)), D)


def test_no_underflow_where_the_published_product_would():
    # distances far larger than the first column's spread: exp(-lambda D) is 0 in float64 for every reference, yet
    # the belief is the same as for the distances less their column minimum (the shift cancels)
    rng = np.random.default_rng(3)
    D = rng.uniform(0.0, 1.0, (9, 6))
    far = D + 1e4
    assert np.all(np.exp(-math.log(5) / 0.9 * far[:, 1:]) == 0)
    a, b = run_whole(build(), D), run_whole(build(), far)
    assert np.array_equal(a[2], b[2])
    np.testing.assert_allclose(a[1], b[1], rtol=1e-9)
    np.testing.assert_allclose(a[3], b[3], rtol=1e-9)


def test_a_peak_on_the_last_reference_with_an_empty_neighbourhood():
    # the neighbourhood leaves the last reference out; query 1 puts all the belief there (the other references are
    # 1e5 further than the first column's spread: their belief is exactly 0), so the neighbourhood {0, 1} holds no
    # mass: the match is the peak and the native confidence 0 (the published code divides by zero there)
    D = np.array([[0.0, 1e5], [1.0, 1e5], [2.0, 0.0]])
    queries, scores, match, native = run_whole(build((0, 2)), D)
    assert match.tolist()[1] == 2 and native[1] == 0.0
    assert scores[1].tolist() == [np.inf, np.inf, 0.0]
