"""``openseqslam`` (method §14): equal to a naive implementation written here from the method's text (Python loops
over queries, references, velocities and steps), on random matrices and on a case worked out by hand; block-wise
equal to the whole split through ``features.match_blocks`` and ``split_features``; its bad settings and too small
splits refused naming the setting and the fix."""

from __future__ import annotations

import math
from fractions import Fraction

import h5py
import numpy as np
import pytest

from vpr_smr.eval.matching import matcher as matcher_module
from vpr_smr.eval.matching.features import match_blocks, split_features
from vpr_smr.eval.matching.matchers import MatcherSpec, matcher_class
from vpr_smr.eval.matching.matchers.openseqslam import OpenSeqSLAM, OpenSeqSLAMSettings

INF = math.inf


def naive(d, seq_len, enhance_window=10, v_min=0.8, v_max=1.2, ratio_window=10, alignment="centred"):
    """{query: (s_a as a list, match, ratio)} by the method's text, one number at a time. Sums run in the order the
    text reads them (rows of a window top to bottom, steps k = 0 .. ds), so the numbers are equal, not close. A
    window of equal distances has no enhanced value (it is left out: +inf); a start whose match would be past the
    last reference is no candidate."""
    n_ref, n_query = d.shape
    ds = seq_len + seq_len % 2
    half = enhance_window // 2
    enhanced = [[0.0] * n_query for _ in range(n_ref)]
    for q in range(n_query):
        for r in range(n_ref):
            window = [float(d[i, q]) for i in range(max(0, r - half), min(n_ref, r + half + 1))]
            if all(x == window[0] for x in window):
                enhanced[r][q] = INF
                continue
            total = 0.0
            for x in window:
                total += x
            mean = total / len(window)
            squares = 0.0
            for x in window:
                squares += (x - mean) * (x - mean)
            enhanced[r][q] = (float(d[r, q]) - mean) / math.sqrt(squares / (len(window) - 1))
    low = min(min(row) for row in enhanced)
    dd = [[x - low for x in row] for row in enhanced]
    moves = range(math.floor(Fraction(str(v_min)) * ds), math.floor(Fraction(str(v_max)) * ds) + 1)
    offset = ds // 2 if alignment == "centred" else ds
    queries = range(ds // 2, n_query - ds // 2) if alignment == "centred" else range(ds, n_query)
    out = {}
    for a in queries:
        first = a - offset
        score = []
        for s in range(n_ref - offset):  # the candidates: starts whose match s + offset is a reference
            best = INF
            for m in moves:
                total = 0.0
                for k in range(ds + 1):
                    row = s + k * m // ds
                    total += dd[row][first + k] if row < n_ref else INF
                best = min(best, total)
            score.append(best)
        s_star = min(range(len(score)), key=lambda s: (score[s], s))
        w = ratio_window // 2
        window = range(max(0, s_star - w), min(n_ref, s_star + w))
        second = min(score[s] for s in range(len(score)) if s not in window)
        ratio = 1.0 if second == 0 else score[s_star] / second
        s_a = [INF] * offset + score
        out[a] = (s_a, s_star + offset, ratio)
    return out


def run(d, seq_len, block_queries=None, **values):
    matcher = MatcherSpec.of("openseqslam", values).build(seq_len)
    matcher.check(d.shape)
    blocks = [found for found, _, _ in match_blocks(matcher, d, block_queries)]
    return (np.concatenate([b.queries for b in blocks]), np.concatenate([b.scores for b in blocks]),
            np.concatenate([b.match for b in blocks]), np.concatenate([b.native for b in blocks]))


def assert_naive(d, seq_len, **values):
    expected = naive(d.astype(np.float64), seq_len, **values)
    queries, scores, match, native = run(d, seq_len, **values)
    assert queries.tolist() == sorted(expected)
    assert scores.tolist() == [expected[a][0] for a in queries]
    assert match.tolist() == [expected[a][1] for a in queries]
    assert (-native).tolist() == [expected[a][2] for a in queries]
    return queries, match, native


SETTINGS = [{}, {"enhance_window": 4, "v_min": 0.5, "v_max": 1.5, "ratio_window": 4}, {"v_min": 1.0, "v_max": 1.0},
            {"enhance_window": 80}]  # the last: every window is the whole column


@pytest.mark.parametrize("alignment", ["centred", "trailing"])
@pytest.mark.parametrize("seq_len", [3, 4, 5, 6])
@pytest.mark.parametrize("values", SETTINGS)
def test_equal_to_the_naive_implementation_on_random_matrices(alignment, seq_len, values):
    rng = np.random.default_rng(seq_len)
    d = rng.random((31, 29))  # more evaluated queries than a tile of TILE_QUERIES
    assert_naive(d, seq_len, alignment=alignment, **values)


def test_float32_matrices_are_matched_in_float64():
    d = np.random.default_rng(5).random((30, 12)).astype(np.float32)
    assert_naive(d, 4)


def test_ties_go_to_the_lowest_reference():
    # three equal periods of 16 rows: starts 16 apart whose windows and trajectories stay off the first and last
    # rows see the same enhanced values bit for bit, so their scores tie; the ratio of such a match is then 1
    block = np.random.default_rng(11).random((16, 14))
    d = np.vstack([block, block, block])
    queries, match, native = assert_naive(d, 4, enhance_window=2, ratio_window=4)
    tied = native == -1.0
    assert tied.sum() >= len(queries) // 2
    assert np.all(match[tied] < 32)  # the lowest of the tied starts


def test_a_case_worked_out_by_hand():
    # D[r, q] = |r - p_q| with vertices p = 2, 3, 5 (R = 8, Q = 3); E = 2: windows of rows r-1 .. r+1.
    # A window on a straight slope has the entry at its mean: 0. The vertex [1, 0, 1]: mean 2/3, std 1/sqrt(3),
    # (0 - 2/3) sqrt(3) = -2/sqrt(3), the split's minimum. The end rows [2, 1] or [1, 2] etc.: (+1/2) / (1/sqrt(2))
    # = +1/sqrt(2). After the minimum: vertex 0, slope A = 2/sqrt(3), end B = 1/sqrt(2) + 2/sqrt(3):
    #   col 0: B A 0 A A A A B     col 1: B A A 0 A A A B     col 2: B A A A A 0 A B
    # L = 2: ds = 2, v_min = v_max = 1 (moves 0, 1, 2), the query a = 1 reads columns 0..2 (centred).
    # score[s] = col0[s] + col1[s+1] + col2[s+2]: s=0: B+2A, 1: 3A, 2: 0+0+A = A, 3: A+A+0 = 2A, 4: 3A, 5: 2A+B,
    # 6 and 7 leave the references (+inf). s* = 2, the match s* + 1 = 3. ratio_window 2 leaves out starts 1, 2: the
    # second best 2A (s = 3), ratio 1/2; ratio_window 4 leaves out 0..3: the second best 3A, ratio 1/3.
    d = np.abs(np.arange(8)[:, None] - np.array([2, 3, 5])[None, :]).astype(np.float64)
    a, b = 2 / math.sqrt(3), 1 / math.sqrt(2) + 2 / math.sqrt(3)
    for ratio_window, ratio in ((2, 0.5), (4, 1 / 3)):
        queries, scores, match, native = run(d, 2, enhance_window=2, v_min=1.0, v_max=1.0, ratio_window=ratio_window)
        assert queries.tolist() == [1]
        assert match.tolist() == [3]
        expected = [INF, b + 2 * a, 3 * a, a, 2 * a, 3 * a, 2 * a + b, INF]  # s_a[r] = score[r - 1]
        assert scores[0].tolist() == pytest.approx(expected, rel=1e-12)
        assert native[0] == pytest.approx(-ratio, rel=1e-12)
    # trailing: the query a = 2 reads columns 0..2, the match s* + 2 = 4; starts 6, 7 would match past the end
    queries, scores, match, native = run(d, 2, enhance_window=2, v_min=1.0, v_max=1.0, ratio_window=2,
                                         alignment="trailing")
    assert (queries.tolist(), match.tolist()) == ([2], [4])
    assert scores[0].tolist() == pytest.approx([INF, INF, b + 2 * a, 3 * a, a, 2 * a, 3 * a, 2 * a + b], rel=1e-12)
    assert native[0] == pytest.approx(-0.5, rel=1e-12)


def test_windows_of_equal_distances_are_left_out():
    # rows 0..9 equal (a train standing still): with E = 4 the windows of rows 0..7 hold equal distances, so no
    # trajectory visits them, as OpenSeqSLAM's min skips their NaN
    d = np.random.default_rng(2).random((40, 12))
    d[1:10] = d[0]
    queries, match, native = assert_naive(d, 4, enhance_window=4)
    matcher = OpenSeqSLAM(4, OpenSeqSLAMSettings(enhance_window=4))
    enhanced = matcher.enhanced(d.T)
    assert np.isinf(enhanced[:, :8]).all() and np.isfinite(enhanced[:, 8:]).all()
    assert np.all(match >= 8 + matcher.offset)


@pytest.mark.parametrize("alignment", ["centred", "trailing"])
@pytest.mark.parametrize("seq_len", [4, 5])
def test_block_wise_equals_the_whole_split(tmp_path, alignment, seq_len):
    d = np.random.default_rng(7).random((40, 23)).astype(np.float32)
    with h5py.File(tmp_path / "d.h5", "w") as out:
        out["d"] = d
    whole = run(d, seq_len, None, alignment=alignment)
    with h5py.File(tmp_path / "d.h5", "r") as source:
        for block_queries in (1, 3):
            for got, want in zip(run(source["d"], seq_len, block_queries, alignment=alignment), whole, strict=True):
                assert np.array_equal(got, want)
    matcher = MatcherSpec.of("openseqslam", {"alignment": alignment}).build(seq_len)
    features = [split_features(matcher, d, 2, block_queries, n_candidates=5) for block_queries in (1, 3, None)]
    assert features[0]["queries"].tolist() == [a for a in whole[0] if a >= seq_len - 1]
    for other in features[1:]:
        assert other.keys() == features[0].keys()
        for key, value in features[0].items():
            assert np.array_equal(other[key], value), key


def test_registered_with_its_defaults():
    assert matcher_class("openseqslam") is OpenSeqSLAM
    spec = MatcherSpec.of("openseqslam")
    assert spec.values == {"enhance_window": 10, "v_min": 0.8, "v_max": 1.2, "ratio_window": 10, "alignment": "centred"}
    matcher = spec.build(9)
    assert (matcher.ds, matcher.lookback, matcher.lookahead) == (10, 5, 5)
    assert matcher.moves[:, -1].tolist() == [8, 9, 10, 11, 12]
    trailing = MatcherSpec.of("openseqslam", {"alignment": "trailing"}).build(4)
    assert (trailing.ds, trailing.lookback, trailing.lookahead) == (4, 4, 0)


@pytest.mark.parametrize(("values", "message"), [
    ({"v_min": 1.3}, r"sequence_matching\.v_min: 1\.3 is above v_max 1\.2: the velocities searched are v_min \.\. "
                     r"v_max; set v_min <= v_max \(default 0\.8 and 1\.2\)"),
    ({"enhance_window": 5}, r"sequence_matching\.enhance_window: 5 is odd; the window reaches enhance_window / 2 "
                            r"references either side, so it must be even: use 4 or 6 \(default 10\)"),
    ({"ratio_window": 7}, r"sequence_matching\.ratio_window: 7 is odd; .* use 6 or 8 \(default 10\)"),
    ({"ratio_window": 0}, r"sequence_matching\.ratio_window: .*must be >= 2, got 0"),
    ({"v_min": 0}, r"sequence_matching\.v_min: .*must be > 0, got 0"),
    ({"alignment": "causal"}, r"sequence_matching\.alignment: 'causal' is not one of centred, trailing"),
])
def test_bad_settings_are_refused_naming_the_setting(values, message):
    with pytest.raises(ValueError, match=message):
        MatcherSpec.of("openseqslam", values)


def test_a_split_too_small_is_refused_naming_what_it_needs():
    matcher = MatcherSpec.of("openseqslam").build(4)  # ds 4, moves 3..4, offset 2, ratio_window 10
    with pytest.raises(ValueError, match=r"^val split has 4 query columns; openseqslam at L = 4 \(ds = 4\) reads 5 "
                                         r"consecutive ones per query, so it needs at least 5$"):
        matcher.check((100, 4), "val split")
    matcher.check((14, 5))
    with pytest.raises(ValueError, match=r"^distance matrix has 13 references; openseqslam at L = 4 \(ds = 4\) "
                                         r"with v_min 0\.8, alignment centred and ratio_window 10 needs at least "
                                         r"14, so that a second best lies outside the ratio's window: lower "
                                         r"openseqslam\.ratio_window or give more references$"):
        matcher.check((13, 5))


def test_a_matrix_of_equal_windows_throughout_is_refused():
    with pytest.raises(ValueError, match=r"openseqslam's local contrast enhancement is undefined throughout this "
                                         r"20 x 9 distance matrix: every window of 11 reference rows holds equal "
                                         r"distances; use another descriptor or matcher for this split"):
        run(np.ones((20, 9)), 4)


def test_a_query_left_without_a_second_best_is_named():
    # 30 rows, the first 26 equal: with E = 10 only rows 21..29 are defined, so the finite starts are 21..26
    # (moves 3 and 4 from there stay within row 29); ratio_window 12 leaves out s* - 6 .. s* + 5, all of them
    d = np.random.default_rng(4).random((30, 9))
    d[:26] = d[0]
    with pytest.raises(ValueError, match=r"^openseqslam: query 2 of the distance matrix \(match 26\) has no finite "
                                         r"score outside the ratio's window of 12 references around its match: its "
                                         r"trajectories visit distances whose enhancement window holds equal "
                                         r"distances \(duplicate reference frames\) or leave the references; use a "
                                         r"longer split, lower openseqslam\.ratio_window, or another matcher$"):
        run(d, 4, ratio_window=12)


def test_a_block_without_the_splits_minimum_is_refused():
    matcher = MatcherSpec.of("openseqslam").build(4)
    with pytest.raises(ValueError, match=r"start from prepare\(matrix\) over the whole split"):
        matcher.block(np.ones((5, 20)), 0, None)


@pytest.mark.parametrize("enhance_window", [2, 4, 10, 30])
def test_the_compiled_enhancement_equals_the_numpy_path_bit_for_bit(enhance_window):
    pytest.importorskip("numba")
    from vpr_smr.eval.matching import openseqslam_kernels

    matcher = OpenSeqSLAM(4, OpenSeqSLAMSettings(enhance_window=enhance_window))
    rng = np.random.default_rng(enhance_window)
    for n_ref in (3, 7, 40, 511, 512, 513, 1100):  # shorter than the window, around the kernel's tile of 512 rows
        values = rng.random((5, n_ref))
        values[:, 2:9] = 0.25  # windows of equal distances (+inf)
        values[1] = 0.5  # a column of equal distances throughout
        out = np.empty_like(values)
        openseqslam_kernels.enhance(values, enhance_window // 2, out)
        assert np.array_equal(out, matcher.enhanced(values))  # matcher.kernels is None: the numpy path


@pytest.mark.parametrize("alignment", ["centred", "trailing"])
def test_the_compiled_path_gives_the_numpy_paths_features(monkeypatch, alignment):
    pytest.importorskip("numba")
    d = np.random.default_rng(5).random((60, 30)).astype(np.float32)
    features = {}
    for kind in ("numpy", "numba"):
        monkeypatch.setattr(matcher_module, "KERNEL", kind)
        built = MatcherSpec.of("openseqslam", {"alignment": alignment}).build(4)
        features[kind] = split_features(built, d, 3, 7, n_candidates=5)
        assert (built.kernels is not None) == (kind == "numba")
    assert features["numpy"].keys() == features["numba"].keys()
    for key, value in features["numpy"].items():
        assert np.array_equal(features["numba"][key], value), key
