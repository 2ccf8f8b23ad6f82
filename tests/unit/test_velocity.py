"""SeqSLAM's velocity search (method §11): ``SequenceMatcher.block_features`` against a literal per-query
transcription of the definition, against the fixed slope-1 matcher at ``V = {1}``, block-wise against whole, on a
query driven 1.5 times as fast as the references, its errors, and the compiled kernel against the numpy path.

Every comparison of values is exact (``assert_array_equal``): the definition fixes the order of every addition.
"""

import subprocess
import sys

import numpy as np
import pytest
from helpers import REPO
from oracles import KEYS, naive_features

from vpr_smr.core.constants import EPS
from vpr_smr.eval.matching import fixed, matcher, velocity
from vpr_smr.eval.matching.matcher import SequenceMatcher, read_columns


def velocity_block_features(columns, seq_len, n_ranks, velocities, first_column=0):
    return SequenceMatcher(seq_len, velocities).block_features(columns, n_ranks, first_column)


def features(matrix, seq_len, n_ranks, velocities, **kwargs):
    """``velocity_block_features`` of the whole matrix as one block."""
    return velocity_block_features(read_columns(np.asarray(matrix), 0, matrix.shape[1]), seq_len, n_ranks, velocities,
                                   **kwargs)


def assert_same(result, expected, keys=KEYS):
    for key in keys:
        np.testing.assert_array_equal(result[key], expected[key], err_msg=key, strict=False)
        assert result[key].dtype == (np.int64 if key in ("rank_references", "single_match", "sequence_match")
                                     else np.float64), key


def assert_bit_identical(a, b, keys=KEYS):
    for key in keys:
        assert a[key].dtype == b[key].dtype and a[key].shape == b[key].shape, key
        assert a[key].tobytes() == b[key].tobytes(), key


# --- matrices -----------------------------------------------------------------------------------------------------


def repeated_matrix(n_ref=24, n_query=16, seed=4):
    """Small integers with repeated identical reference rows (a stopped train) and repeated query columns."""
    rng = np.random.default_rng(seed)
    matrix = rng.integers(0, 4, (n_ref, n_query)).astype(np.float32)
    matrix[8:13] = matrix[8]
    matrix[:, 5:9] = matrix[:, 5:6]
    return matrix


def small_matrices():
    rng = np.random.default_rng(7)
    yield "random float64", rng.random((23, 14))
    yield "random float32", rng.random((17, 12), dtype=np.float32)
    yield "integers 0..2", rng.integers(0, 3, (20, 13)).astype(np.float64)
    yield "repeated rows and columns", repeated_matrix()
    yield "zero column", np.where(np.arange(11) == 4, 0.0, rng.integers(0, 5, (19, 11)).astype(np.float64))


VELOCITY_SETS = [(1.0,), (0.5, 1.0, 2.0), (0.8, 1.0, 1.25), (0.7, 1.3), (2.0, 3.0), (0.25, 0.5),
                 (1.4, 0.6), (1.15, 0.85)]  # the last two: equally close to 1 as written, not in float64


def test_the_tie_order_reads_the_velocities_as_written():
    # method §11: closest to 1, then the smaller; |0.6 - 1| > |1.4 - 1| in float64, equal as written
    assert matcher.search_order((1.4, 0.6)) == (0.6, 1.4)
    assert matcher.search_order((1.15, 0.85, 2.0, 1.0)) == (1.0, 0.85, 1.15, 2.0)


@pytest.mark.parametrize("velocities", VELOCITY_SETS, ids=str)
@pytest.mark.parametrize("seq_len", [2, 3, 5])
@pytest.mark.parametrize("name, matrix", list(small_matrices()), ids=[name for name, _ in small_matrices()])
def test_equals_naive_definition(name, matrix, seq_len, velocities):
    r_min = matcher.first_reference(seq_len, velocities)
    n_ranks = min(4, matrix.shape[0] - r_min)
    assert_same(features(matrix, seq_len, n_ranks, velocities), naive_features(matrix, seq_len, n_ranks, velocities))


@pytest.mark.parametrize("seq_len, velocities", [(5, (2.0, 3.0)), (3, (0.5, 1.0)), (2, (1.0,))])
def test_fewest_references_equal_naive(seq_len, velocities):
    # R = r_min + 1: one end reference with a trajectory (N = 1), one rank; R = r_min + 3: blocks and groups cut short.
    r_min = matcher.first_reference(seq_len, velocities)
    rng = np.random.default_rng(seq_len)
    for n_ref, n_ranks in ((r_min + 1, 1), (r_min + 3, 3)):
        matrix = rng.integers(0, 3, (n_ref, 9)).astype(np.float64)
        expected = naive_features(matrix, seq_len, n_ranks, velocities)
        assert_same(features(matrix, seq_len, n_ranks, velocities), expected)


def test_hand_worked_velocity_choice():
    # L = 3, V = {0.5, 1, 2}: o(0.5) = (1, 1, 0), o(1) = (2, 1, 0), o(2) = (4, 2, 0); r_min = 1; scanned 1, 0.5, 2.
    # One query, a = 2. D is 1 except D[1, 0] = D[3, 1] = D[4, 1] = D[5, 2] = 0; every column's maximum is 1: Dn = D.
    d = np.ones((7, 3))
    d[[1, 3, 4, 5], [0, 1, 1, 2]] = 0.0
    # S_v(r) = D[r - o_0, 0] + D[r - o_1, 1] + D[r, 2]:
    #   r = 1: only 0.5 valid: 1 + 1 + 1 = 3                 -> S 3, v* 0.5
    #   r = 2: 1: 1 + 1 + 1 = 3; 0.5: 0 + 1 + 1 = 2           -> S 2, v* 0.5
    #   r = 3: 1: 0 + 1 + 1 = 2; 0.5: 3                       -> S 2, v* 1
    #   r = 4: 1: 1 + 0 + 1 = 2; 0.5: 1 + 0 + 1 = 2 (a tie); 2: 1 + 1 + 1 = 3  -> S 2, v* 1 (closest to 1)
    #   r = 5: 1: 1 + 0 + 0 = 1; 0.5: 1 (a tie); 2: 0 + 0 + 0 = 0             -> S 0, v* 2
    #   r = 6: 1: 3; 0.5: 3; 2: D[2, 0] + D[4, 1] + D[6, 2] = 2               -> S 2, v* 2
    # full (i = r - 1) = [3, 2, 2, 2, 0, 2]; past = [2, 1, 1, 1, 0, 1]; ranks 4, then 1 (lowest i of the tied 2s).
    # rowpast (r = 0..6) = [2, 1, 2, 1, 1, 2, 2]; current column [1, 1, 1, 1, 1, 0, 1].
    # Rank 1 (i = 1): block {0, 1, 2} has mean full 7/3, group {0 .. 3} 9/4, its last entry D[2, 2] = 1.
    out = features(d, 3, 2, (0.5, 1.0, 2.0))
    e = EPS
    assert out["sequence_match"].tolist() == [5]
    assert out["sequence_distance"].tolist() == [0.0]
    assert out["sequence_velocity"].tolist() == [2.0]
    assert out["sequence_max"].tolist() == [3.0]
    assert out["single_match"].tolist() == [5]
    assert out["rank_references"].tolist() == [[5, 2]]
    np.testing.assert_array_equal(out["attributes"][0], [[0.0, 0.0, 0.0, 0.0],
                                                          [1 / (1 + e), 1 / (1 + e), 1 / (7 / 3 + e), 1 / (9 / 4 + e)]])


# --- V = {1} is the fixed matcher --------------------------------------------------------------------------------


def tied_matrix(n_ref=260, n_query=90, seed=3):
    """A stopped train: reference rows 100..115 are one frame repeated and close to every query, query columns
    40..70 one frame repeated; so the best trajectories of many queries tie exactly."""
    rng = np.random.default_rng(seed)
    matrix = rng.random((n_ref, n_query)).astype(np.float32) + 0.5
    matrix[100:116] = rng.random(n_query).astype(np.float32) * 0.1
    matrix[:, 40:71] = matrix[:, 40:41]
    return matrix


def fixed_matrices():
    rng = np.random.default_rng(21)
    yield "random float32", rng.random((300, 70), dtype=np.float32)
    yield "random float64, negative", rng.random((200, 60)) - 0.6
    yield "tied rows and columns", tied_matrix()
    yield "integer-valued float32", rng.integers(0, 3, (250, 50)).astype(np.float32)
    yield "integers 0..3", rng.integers(0, 4, (120, 40))


@pytest.mark.parametrize("seq_len", [2, 4, 10])
@pytest.mark.parametrize("name, matrix", list(fixed_matrices()), ids=[name for name, _ in fixed_matrices()])
def test_velocity_one_is_the_fixed_matcher_bit_for_bit(name, matrix, seq_len):
    # the fast path of the fixed matcher (diagonal running sums) against the velocity search's twin at V = {1}
    columns = read_columns(matrix, 0, matrix.shape[1]).astype(matrix.dtype if matrix.dtype.kind == "f" else float)
    fast = fixed.block_features(columns, seq_len, 4, np.float32, 0, None)
    table = matcher.offsets(1.0, seq_len)[None]
    result = velocity.block_features(columns, velocity.column_max(columns, 0), table, seq_len - 1, 4)
    assert_bit_identical(result, fast, keys=tuple(fast))
    assert set(result) == set(fast) | {"sequence_index"}
    assert np.all(result["sequence_index"] == 0)


# --- block-wise equals whole ----------------------------------------------------------------------------------------


def blockwise(matrix, seq_len, n_ranks, velocities, step):
    """Blocks of ``step`` queries (``step + L - 1`` columns each), as ``SequenceMatcher.map_blocks`` reads them."""
    n_out = matrix.shape[1] - seq_len + 1
    parts = [velocity_block_features(read_columns(matrix, start, min(n_out, start + step) + seq_len - 1), seq_len,
                                     n_ranks, velocities) for start in range(0, n_out, step)]
    return {key: np.concatenate([part[key] for part in parts]) for key in KEYS}


@pytest.mark.parametrize("velocities", [(0.5, 1.0, 2.0), (0.7, 1.3), (2.0, 3.0)], ids=str)
@pytest.mark.parametrize("seq_len", [2, 5])
def test_blockwise_equals_whole_exactly(seq_len, velocities):
    matrix = tied_matrix(n_ref=200, n_query=60)
    whole = blockwise(matrix, seq_len, 4, velocities, matrix.shape[1])
    for step in (1, 7):
        assert_bit_identical(blockwise(matrix, seq_len, 4, velocities, step), whole)
    # and the numpy path's own chunks of queries do not matter either
    previous, velocity.CHUNK_VALUES = velocity.CHUNK_VALUES, 1
    try:
        assert_bit_identical(blockwise(matrix, seq_len, 4, velocities, matrix.shape[1]), whole)
    finally:
        velocity.CHUNK_VALUES = previous


# --- a query driven 1.5 times as fast as the references -------------------------------------------------------------


def driven(speed, n_ref=300, dim=16, noise=1.3, seed=0):
    """Distances of a query traverse that advances ``speed`` places per frame (frame t shows place
    ``floor(speed t + 0.5)``, method §11's simulated profile) and the true place of each query frame.

    Each place has a random descriptor, smoothed over its two neighbours (so a place looks like the next one, not
    like one 2 or more away); a query frame is its place's descriptor plus noise, strong enough that single-frame
    matching is often wrong. D is the squared Euclidean distance."""
    rng = np.random.default_rng(seed)
    white = rng.normal(size=(n_ref + 2, dim))
    places = (white[:-2] + 2 * white[1:-1] + white[2:]) / np.sqrt(6)
    n_query = int((n_ref - 1) / speed)
    truth = np.floor(speed * np.arange(n_query) + 0.5).astype(int)
    queries = places[truth] + noise * rng.normal(size=(n_query, dim))
    distances = ((places[:, None, :] - queries[None, :, :]) ** 2).sum(-1)
    return distances.astype(np.float32), truth


def test_velocity_search_follows_a_faster_query():
    # Slope 1 against a query moving at 1.5: its trajectory of L = 10 frames drifts 4.5 places from the true ones,
    # so at most 2-3 of its 10 cells lie on the query's places, and which end reference wins is left to the noise
    # (about half within 2 places). The trajectories of slope 1.5 (or the grid's 2^(2/4) = 1.41 and 2^(3/4) = 1.68)
    # stay within one place of the truth over all 10 frames.
    distances, truth = driven(1.5)
    seq_len = 10
    truth = truth[seq_len - 1 :]

    def correct(velocities):
        out = features(distances, seq_len, 1, velocities)
        reference = out["sequence_match"]
        return np.mean(np.abs(reference - truth) <= 2), out

    single = np.mean(np.abs(np.argmin(distances, axis=0)[seq_len - 1 :] - truth) <= 2)
    fixed, _ = correct((1.0,))
    searched, out = correct((1.0, 1.5))
    grid, _ = correct(tuple(2 ** (k / 4) for k in range(-4, 5)))
    assert single < 0.5  # the noise makes single frames unreliable
    assert fixed <= 0.6
    assert searched == 1.0 and grid >= 0.98
    assert np.mean(out["sequence_velocity"] == 1.5) >= 0.95


# --- errors ---------------------------------------------------------------------------------------------------------


def test_non_finite_values_name_the_block():
    matrix = np.random.default_rng(0).random((30, 12))
    matrix[4, 9] = np.nan
    # one block alone: its count, its columns, the first bad value in the matrix's own indices
    with pytest.raises(ValueError, match=r"1 non-finite value \(1 NaN\) in query columns 3\.\.11; the first is NaN "
                                         r"at row 4 \(reference\), column 9 \(query\)"):
        velocity_block_features(read_columns(matrix, 3, 12), 3, 2, (1.0, 2.0), first_column=3)
    matrix[4, 9] = np.inf
    with pytest.raises(ValueError, match="non-finite"):
        features(matrix, 3, 2, (1.0,))


def test_too_few_references_for_the_velocities():
    # L = 5 at v = 2: o_0 = 8, so the first end reference with a trajectory is 8; 8 references have none.
    matrix = np.ones((8, 10))
    too_few = r"8 references are too few for sequence length 5 at velocities \[2\.0, 3\.0\]"
    with pytest.raises(ValueError, match=too_few):
        features(matrix, 5, 1, (2.0, 3.0))
    assert features(np.ones((9, 10)), 5, 1, (2.0, 3.0))["rank_references"].tolist() == [[8]] * 6


@pytest.mark.parametrize("call, message", [
    (lambda m: features(m, 3, 2, ()), "at least one velocity"),
    (lambda m: features(m, 3, 2, (1.0, -1.0)), "each > 0"),
    (lambda m: features(m, 1, 2, (1.0,)), "sequence length must be at least 2"),
    (lambda m: velocity_block_features(m.T[:2], 3, 2, (1.0,)), "holds no query of sequence length 3"),
    (lambda m: features(m, 3, 9, (1.0,)), r"n_ranks must be 1 \.\. 8"),
    (lambda m: velocity_block_features(m.astype(str).T, 3, 2, (1.0,)), "expected a numeric matrix"),
])
def test_bad_arguments(call, message):
    with pytest.raises(ValueError, match=message):
        call(np.ones((10, 6)))


# --- the compiled kernel ------------------------------------------------------------------------------------------


def with_kernel(kernel, function, *args):
    previous, matcher.KERNEL = matcher.KERNEL, kernel
    try:
        return function(*args)
    finally:
        matcher.KERNEL = previous


def compiled_matrices():
    rng = np.random.default_rng(31)
    yield "random float32", rng.random((300, 60), dtype=np.float32)
    yield "random float64, negative", rng.random((150, 40)) - 0.6
    yield "tied rows and columns", tied_matrix()
    yield "integer-valued float32", rng.integers(0, 3, (200, 50)).astype(np.float32)
    yield "repeated rows and columns", repeated_matrix(60, 30)
    yield "zero column", np.where(np.arange(30) == 4, 0.0, rng.integers(0, 5, (90, 30)).astype(np.float64))
    yield "integers 0..3", rng.integers(0, 4, (80, 25))


@pytest.mark.parametrize("velocities", [(1.0,), (0.5, 1.0, 2.0), (0.7, 1.3), (2.0, 3.0), (0.25, 0.5)], ids=str)
@pytest.mark.parametrize("seq_len", [2, 5, 10])
def test_compiled_equals_numpy_exactly(seq_len, velocities):
    pytest.importorskip("numba")
    for _, matrix in compiled_matrices():
        columns = read_columns(matrix, 0, matrix.shape[1])
        numpy_path = with_kernel("numpy", velocity_block_features, columns, seq_len, 4, velocities)
        compiled = with_kernel("numba", velocity_block_features, columns, seq_len, 4, velocities)
        assert_bit_identical(compiled, numpy_path)
        # a block that is not contiguous (columns of a Fortran-ordered matrix) gives the same on both paths
        strided = np.asfortranarray(matrix).T
        assert_bit_identical(with_kernel("numba", velocity_block_features, strided, seq_len, 4, velocities), numpy_path)


def test_compiled_kernel_equals_naive_and_is_chosen_by_size(monkeypatch):
    pytest.importorskip("numba")
    matrix = repeated_matrix()
    expected = naive_features(matrix, 3, 4, (0.5, 1.0, 2.0))
    assert_same(with_kernel("numba", features, matrix, 3, 4, (0.5, 1.0, 2.0)), expected)
    # auto: numpy for a small run, the compiled kernel for a large one; VPR_SMR_KERNEL=numpy wins
    monkeypatch.delenv("VPR_SMR_KERNEL", raising=False)
    assert matcher.velocity_kernels(100, 100) is None
    assert matcher.velocity_kernels(matcher.LOADED_MIN_WORK, 0) is not None  # loaded above: no fixed cost left
    assert matcher.velocity_kernels(100, matcher.KERNEL_MIN_WORK) is not None
    monkeypatch.setenv("VPR_SMR_KERNEL", "numpy")
    assert matcher.velocity_kernels(100, matcher.KERNEL_MIN_WORK) is None
    monkeypatch.setenv("VPR_SMR_KERNEL", "numba")
    assert matcher.velocity_kernels(100, 100) is not None


def test_benchmark_runs_small():
    script = REPO / "benchmarks" / "velocity.py"
    done = subprocess.run([sys.executable, str(script), "--small"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.count("ratio velocity / fixed") >= 12, done.stdout
