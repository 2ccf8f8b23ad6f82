"""The fixed matcher's numpy path on several threads (``VPR_SMR_THREADS``): each block of query columns computed
alone on a pool thread, the results in the blocks' order, so every number equals the definition's and one thread's,
bit for bit, and a bad value is reported as on one thread."""

import os
import threading

import numpy as np
import pytest
from oracles import naive_attributes, naive_sequence, tied_matrix

from vpr_smr.eval.matching import fixed, matcher
from vpr_smr.eval.matching.matcher import THREADS_VARIABLE, SequenceMatcher, thread_count


@pytest.fixture
def numpy_path(monkeypatch):
    monkeypatch.setattr(matcher, "KERNEL", "numpy")
    return monkeypatch


def run(monkeypatch, threads, matrix, seq_len, **kwargs):
    """``features`` on ``threads`` threads, and the threads its blocks ran on."""
    monkeypatch.setenv(THREADS_VARIABLE, str(threads))
    ran_on, original = set(), fixed.numpy_block_features

    def recorded(*args, **kw):
        ran_on.add(threading.get_ident())
        return original(*args, **kw)

    monkeypatch.setattr(fixed, "numpy_block_features", recorded)
    try:
        return SequenceMatcher(seq_len).features(matrix, 4, **kwargs), ran_on
    finally:
        monkeypatch.setattr(fixed, "numpy_block_features", original)


@pytest.mark.parametrize("seq_len", [2, 5])
def test_threads_give_the_definition_and_one_threads_bits(numpy_path, seq_len):
    matrix = tied_matrix(n_ref=300, n_query=90)  # exact ties across blocks of 16 queries
    one, ran_on_one = run(numpy_path, 1, matrix, seq_len, block_queries=16, n_candidates=12)
    three, ran_on_three = run(numpy_path, 3, matrix, seq_len, block_queries=16, n_candidates=12)
    assert ran_on_one == {threading.main_thread().ident}
    assert ran_on_three and threading.main_thread().ident not in ran_on_three  # on the pool's threads
    assert one.keys() == three.keys()
    for key in one:
        assert one[key].dtype == three[key].dtype
        np.testing.assert_array_equal(three[key], one[key], err_msg=key)
    expected, expected_refs = naive_attributes(matrix.astype(np.float64), seq_len, 4)
    np.testing.assert_allclose(three["attributes"], expected, rtol=1e-12)
    np.testing.assert_array_equal(three["rank_references"], expected_refs)
    np.testing.assert_array_equal(three["sequence_match"], naive_sequence(matrix.astype(np.float64), seq_len)[1])


def test_one_block_runs_on_the_calling_thread(numpy_path):
    _, ran_on = run(numpy_path, 4, np.random.default_rng(0).random((40, 30)), 3)
    assert ran_on == {threading.main_thread().ident}


def test_the_first_bad_block_in_order_is_reported(numpy_path):
    matrix = np.random.default_rng(0).random((50, 64))
    matrix[7, 3] = np.inf  # the first block
    matrix[30, 60] = np.nan  # the last block, which a pool thread may reach first
    message = (r"has 2 non-finite values \(1 NaN, 1 inf\); the first is inf at row 7 \(reference\), column 3 "
               r"\(query\)")
    for threads in (1, 3):
        numpy_path.setenv(THREADS_VARIABLE, str(threads))
        with pytest.raises(ValueError, match=message):
            SequenceMatcher(3).features(matrix, 4, block_queries=8)


@pytest.mark.parametrize("value", ["0", "two", "-1", "1.5"])
def test_a_bad_thread_count_names_the_variable(monkeypatch, value):
    monkeypatch.setenv(THREADS_VARIABLE, value)
    with pytest.raises(ValueError, match=rf"VPR_SMR_THREADS='{value}': expected a whole number of threads, at "
                                         r"least 1 \(or unset it"):
        thread_count()


def test_thread_count_defaults_to_the_usable_cores(monkeypatch):
    if not hasattr(os, "sched_getaffinity"):
        pytest.skip("the usable cores are known on Linux")
    monkeypatch.delenv(THREADS_VARIABLE, raising=False)
    assert thread_count() == len(os.sched_getaffinity(0))
    monkeypatch.setenv(THREADS_VARIABLE, " 3 ")
    assert thread_count() == 3


# --- A2's smallest current values, read from the selection of the raw ones ---------------------------------------


def bits(values):
    return np.ascontiguousarray(values, dtype=np.float64).view(np.int64)  # tells -0.0 from 0.0


def negative_column():
    matrix = np.random.default_rng(4).random((60, 30)) - 0.7
    matrix[:, 10] = -np.random.default_rng(5).random(60) - 0.1  # a negative maximum reverses the order
    return matrix


def underflow_column():
    matrix = np.random.default_rng(6).random((40, 12)) + 1.0
    matrix[0, 8] = 1e300  # the column's maximum
    matrix[5, 8] = 0.0  # 0 / 1e300 = 0.0
    matrix[20, 8] = -1e-300  # -1e-300 / 1e300 underflows to -0.0: equal to row 5's 0.0, lower raw value
    return matrix


@pytest.mark.parametrize("candidates", [0, 12])
@pytest.mark.parametrize("name, matrix", [("negative maximum", negative_column()),
                                          ("underflow to -0.0", underflow_column())])
def test_current_values_equal_the_definition_bit_for_bit(numpy_path, name, matrix, candidates):
    expected, _ = naive_attributes(matrix, 3, 4)  # the sorted current values of D / max: a stable sort, as §5
    for threads in (1, 2):
        numpy_path.setenv(THREADS_VARIABLE, str(threads))
        found = SequenceMatcher(3).features(matrix, 4, block_queries=5, n_candidates=candidates)
        # A2 = the k-th smallest current value over the rank-k diagonal's last value, one division each
        np.testing.assert_array_equal(bits(found["attributes"][..., 1]), bits(expected[..., 1]), err_msg=name)
        np.testing.assert_array_equal(found["single_match"], matrix.argmin(axis=0)[2:])


# --- the two screenings: direct sums (short windows) and running sums (long ones) --------------------------------


@pytest.mark.parametrize("seq_len", [2, 3, 7, 9, 12])
def test_direct_and_running_sums_give_the_definition(numpy_path, seq_len):
    matrix = tied_matrix(n_ref=200, n_query=60)
    expected, expected_refs = naive_attributes(matrix.astype(np.float64), seq_len, 4)
    found = {}
    for direct_max in (0, 100):  # every length on running sums, then on direct sums
        numpy_path.setattr(fixed, "DIRECT_MAX_LEN", direct_max)
        for screen in (np.float32, np.float64):
            out = SequenceMatcher(seq_len).features(matrix, 4, block_queries=16, screen_dtype=screen,
                                                    n_candidates=12)
            np.testing.assert_allclose(out["attributes"], expected, rtol=1e-12)
            np.testing.assert_array_equal(out["rank_references"], expected_refs)
            found[direct_max, screen] = out
    first = found[0, np.float32]
    for out in found.values():
        for key in first:
            np.testing.assert_array_equal(out[key], first[key], err_msg=key)


def test_the_numpy_path_uses_at_most_its_thread_limit(numpy_path):
    numpy_path.setattr(matcher, "FIXED_MAX_THREADS", 2)
    _, ran_on = run(numpy_path, 8, tied_matrix(n_ref=200, n_query=120), 3, block_queries=8)  # 15 blocks
    assert 1 <= len(ran_on) <= 2
