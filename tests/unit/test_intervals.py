"""The bootstrap over queries (method §8.7) against the naive one: draw the queries' indices (runs of consecutive
queries, ``helpers.bootstrap_indices``), take the drawn queries
(repeats and all) and score them with the functions that score a split (curves, scikit-learn)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import bootstrap_indices
from sklearn.metrics import average_precision_score

from vpr_smr.eval.scoring import curves
from vpr_smr.eval.scoring import intervals as iv

N = 37
DRAWS = 40


def _split(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    distances = np.round(rng.uniform(0, 3, N), 1)  # one decimal: many ties, as real sequence distances have
    correct = rng.random(N) < 0.6
    keep = rng.random(N) < 0.7
    return distances, correct, keep


def _drawn_indices(n: int, draws: int) -> np.ndarray:
    return bootstrap_indices(n, draws)


def _weights(n: int, draws: int) -> np.ndarray:
    return np.concatenate(list(iv.query_weights(n, draws)))


def test_weights_are_the_drawn_indices_counted_whatever_the_chunk_size() -> None:
    drawn = bootstrap_indices(N, 250)  # more than one chunk of CHUNK draws
    expected = np.stack([np.bincount(row, minlength=N) for row in drawn])
    np.testing.assert_array_equal(_weights(N, 250), expected)
    assert (expected.sum(axis=1) == N).all()


def test_a_draw_takes_runs_of_the_cube_root_of_the_queries() -> None:
    # b^3 >= n: 27 -> 3 (not 4, as a floating cube root rounded up would give), 28 -> 4, 2573 -> 14, 1 -> 1
    assert [iv.block_length(n) for n in (1, 2, 8, 9, 27, 28, 2573)] == [1, 2, 2, 3, 3, 4, 14]
    # 10 queries, runs of 3 (4 runs, the last cut to 1): each draw holds whole runs of consecutive queries
    (weights,) = list(iv.query_weights(10, resamples=1))
    start = int(np.random.default_rng(0).integers(0, 10, (1, 4))[0, 0])
    assert weights[0, start] >= 1 and weights[0, (start + 1) % 10] >= 1 and weights[0, (start + 2) % 10] >= 1


@pytest.mark.parametrize("mode", ["paper", "standard"])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_weighted_comparison_is_the_comparison_of_the_drawn_queries(mode: str, seed: int) -> None:
    distances, correct, keep = _split(seed)
    s_min, s_max = 0.0, 3.0
    got = iv.weighted_comparison(mode, distances, correct, keep, _weights(N, DRAWS), s_min, s_max)
    everything = np.ones(N, dtype=bool)
    for draw, idx in enumerate(_drawn_indices(N, DRAWS)):
        d, c, k = distances[idx], correct[idx], keep[idx]
        base = curves.curve(mode, d, c, everything[idx], s_min, s_max)
        pred = curves.curve(mode, d, c, k, s_min, s_max)
        expected = curves.compare_curves(base, pred)
        assert got.aoc_baseline[draw] == pytest.approx(expected.aoc_baseline, abs=1e-12)
        assert got.aoc_predictor[draw] == pytest.approx(expected.aoc_predictor, abs=1e-12)
        if expected.reduction_pct is None:
            assert np.isnan(got.reduction_pct[draw])
        else:
            assert got.reduction_pct[draw] == pytest.approx(expected.reduction_pct, abs=1e-9)


def test_weighted_average_precision_is_scikit_learns_on_the_drawn_queries() -> None:
    rng = np.random.default_rng(5)
    wrong = rng.random(N) < 0.3
    confidence = np.round(rng.normal(size=N), 1)  # ties enter together
    confidence[:3] = np.inf
    got = iv.weighted_average_precision(wrong, confidence, _weights(N, DRAWS))
    for draw, idx in enumerate(_drawn_indices(N, DRAWS)):
        if not wrong[idx].any():
            assert np.isnan(got[draw])
            continue
        finite = np.where(np.isinf(confidence[idx]), 1e300, confidence[idx])  # scikit-learn refuses infinities
        assert got[draw] == pytest.approx(average_precision_score(wrong[idx], -finite), abs=1e-12)


def test_weighted_mean_is_the_mean_of_the_drawn_queries() -> None:
    values = np.random.default_rng(7).random(N)
    got = iv.weighted_mean(values, _weights(N, DRAWS))
    expected = [values[idx].mean() for idx in _drawn_indices(N, DRAWS)]
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_percentile_interval_by_hand() -> None:
    # 0..100: the 2.5th and 97.5th percentiles by linear interpolation are 2.5 and 97.5
    got = iv.percentile_interval(np.arange(101.0))
    assert got is not None and got.low == pytest.approx(2.5) and got.high == pytest.approx(97.5)
    values = np.r_[np.arange(96.0), [np.nan] * 4]  # 96 % defined: NaN left out
    got = iv.percentile_interval(values)
    assert got is not None and got.low == pytest.approx(0.025 * 95) and got.high == pytest.approx(0.975 * 95)
    assert iv.percentile_interval(np.r_[np.arange(94.0), [np.nan] * 6]) is None  # 94 % < MIN_DEFINED


def test_direction_only_when_the_interval_excludes_zero() -> None:
    assert iv.Interval(0.1, 2.0).sign() == 1 and iv.Interval(-3.0, -0.5).sign() == -1
    assert iv.Interval(-0.1, 2.0).sign() == 0 and not iv.Interval(0.0, 1.0).excludes_zero()


def test_a_paired_difference_of_a_number_with_itself_is_exactly_zero() -> None:
    values = np.random.default_rng(8).random(N)

    def mean(weights: np.ndarray) -> np.ndarray:
        return iv.weighted_mean(values, weights)

    assert iv.difference(mean, mean, N) == iv.Interval(0.0, 0.0)


def test_the_interval_of_a_mean_covers_the_normal_approximation() -> None:
    # 400 coin flips with 120 heads: the bootstrap interval of the mean is close to p +- 1.96 sqrt(p(1-p)/n)
    # in a random order (independent neighbours), as runs of consecutive queries are then
    values = np.random.default_rng(3).permutation(np.r_[np.ones(120), np.zeros(280)])
    got = iv.interval(lambda weights: iv.weighted_mean(values, weights), len(values))
    half = 1.96 * np.sqrt(0.3 * 0.7 / 400)
    assert got is not None
    assert got.low == pytest.approx(0.3 - half, abs=0.01) and got.high == pytest.approx(0.3 + half, abs=0.01)
    # the same values in two runs (neighbours alike, as along a route): the runs of 8 consecutive queries carry
    # that, and the interval is more than twice as wide
    runs = np.r_[np.ones(120), np.zeros(280)]
    wide = iv.interval(lambda weights: iv.weighted_mean(runs, weights), len(runs))
    assert wide is not None and wide.high - wide.low > 2 * (got.high - got.low)
