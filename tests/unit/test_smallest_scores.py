"""``features.smallest_scores`` (the candidates of a matcher whose scores are not the attribute sums) against a
naive per-row order by (value, reference): ties, +inf, fewer finite values than asked, NaN."""

import numpy as np
import pytest

from vpr_smr.eval.matching.features import smallest_scores


def naive(scores, count):
    values, references = [], []
    for row in scores.tolist():
        order = sorted(range(len(row)), key=lambda r: (row[r], r))[:count]
        values.append([row[r] for r in order] + [np.inf] * (count - len(order)))
        references.append([r if np.isfinite(row[r]) else -1 for r in order] + [-1] * (count - len(order)))
    return np.array(values, dtype=np.float64).reshape(len(scores), count), np.array(references).reshape(
        len(scores), count)


def test_a_hand_worked_row():
    # values 2 1 inf 1 0 2: ascending 0 (r 4), 1 (r 1), 1 (r 3), 2 (r 0), 2 (r 5), inf (r 2 -> -1), then padding
    values, references = smallest_scores(np.array([[2.0, 1.0, np.inf, 1.0, 0.0, 2.0]]), 8)
    assert values.tolist() == [[0.0, 1.0, 1.0, 2.0, 2.0, np.inf, np.inf, np.inf]]
    assert references.tolist() == [[4, 1, 3, 0, 5, -1, -1, -1]]
    values, references = smallest_scores(np.array([[2.0, 1.0, np.inf, 1.0, 0.0, 2.0]]), 2)
    assert values.tolist() == [[0.0, 1.0]] and references.tolist() == [[4, 1]]


@pytest.mark.parametrize("seed", range(4))
def test_random_rows_with_ties_and_infinities(seed):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        n_rows, n_ref = int(rng.integers(1, 6)), int(rng.integers(1, 30))
        scores = rng.integers(0, 4, (n_rows, n_ref)).astype(np.float64)
        scores[rng.random((n_rows, n_ref)) < 0.3] = np.inf
        for count in (1, 3, 12, 40):
            got, expected = smallest_scores(scores, count), naive(scores, count)
            assert np.array_equal(got[0], expected[0]) and np.array_equal(got[1], expected[1])


def test_nan_is_ordered_last_as_a_sort_orders_it():
    values, references = smallest_scores(np.array([[np.nan, 1.0, 0.0]]), 3)
    assert values[0, :2].tolist() == [0.0, 1.0] and np.isnan(values[0, 2])
    assert references.tolist() == [[2, 1, -1]]
