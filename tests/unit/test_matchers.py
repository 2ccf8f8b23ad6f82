"""The matcher seam (issue 34): the registry by name (and entry point), ``MatcherSpec``, ``seqslam`` behind the base
class, a matcher that is not SeqSLAM going through the shared attributes and candidates code (checked against naive
loops), files of vpr-smr 0.9 (no ``matcher`` record) read as ``seqslam`` with their velocities, and a mismatch
refused naming both matchers."""

import json
import re
from dataclasses import dataclass
from types import SimpleNamespace

import h5py
import numpy as np
import pytest
from helpers import seqslam

from vpr_smr.core.io import read_provenance
from vpr_smr.core.settings import setting
from vpr_smr.eval.matching import matchers as registry
from vpr_smr.eval.matching.attributes import (
    Matching,
    check_matcher,
    check_matching,
    query_features,
    write_features,
)
from vpr_smr.eval.matching.features import match_blocks
from vpr_smr.eval.matching.live import LiveMatcher
from vpr_smr.eval.matching.matcher import read_columns
from vpr_smr.eval.matching.matchers import MatcherSpec, available_matchers, matcher_class
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher
from vpr_smr.eval.matching.matchers.seqslam import SeqSLAM
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.scoring.vpr_metrics import retrieval

# --- two matchers that are not SeqSLAM (they live in this test only) -------------------------------------------


@dataclass(frozen=True)
class ToySettings:
    weight: float = setting(0.5, "weight of the neighbouring columns", exclusive_minimum=0)


class Centred(Matcher):
    """s_a[r] = w D[r-1, a-1] + D[r, a] + w D[r+1, a+1] (a centred window: one column back, one ahead), +inf at the
    first and last reference; the match its argmin."""

    name = "centred_toy"
    Settings = ToySettings
    description = "a centred window of three columns (a test's matcher)"
    native_scorer = "uniqueness"  # its native confidence is a scorer of method §12: its blocks give none

    @property
    def lookback(self):
        return 1

    @property
    def lookahead(self):
        return 1

    def check(self, shape, name="distance matrix"):
        if shape[0] < 3 or shape[1] < 3:
            raise ValueError(f"{name}: at least 3 x 3")

    def block(self, columns, first_column, state):
        c, w = columns.astype(np.float64), self.settings.weight
        n, n_ref = c.shape[0] - 2, c.shape[1]
        scores = np.full((n, n_ref), np.inf)
        scores[:, 1 : n_ref - 1] = w * c[:-2, :-2] + c[1:-1, 1:-1] + w * c[2:, 2:]
        return MatchBlock(first_column + 1 + np.arange(n), scores, np.argmin(scores, axis=1)), state


class Smoothing(Matcher):
    """A filter over every query: s_a = D[:, a] + w s_{a-1} (s_0 = D[:, 0]), the state carried from block to block;
    its match is not its argmin but the single-frame one (a matcher's match is its own)."""

    name = "smoothing_toy"
    Settings = ToySettings
    description = "exponential smoothing of the columns (a test's matcher)"
    native_scorer = "uniqueness"

    @property
    def lookback(self):
        return 0

    def check(self, shape, name="distance matrix"):
        pass

    def initial_state(self):
        return np.zeros(0)  # no column yet

    def block(self, columns, first_column, state):
        rows = []
        for column in columns.astype(np.float64):
            state = column.copy() if state.size == 0 else column + self.settings.weight * state
            rows.append(state)
        match = np.argmin(columns, axis=1)
        return MatchBlock(first_column + np.arange(len(columns)), np.array(rows), match), state


def naive_centred(d, w):
    n_ref, n_query = d.shape
    scores = {}
    for a in range(1, n_query - 1):
        scores[a] = [np.inf] + [w * d[r - 1, a - 1] + d[r, a] + w * d[r + 1, a + 1] for r in range(1, n_ref - 1)] + [
            np.inf]
    return scores, {a: int(np.argmin(s)) for a, s in scores.items()}


def naive_smoothing(d, w):
    scores, previous = {}, None
    for a in range(d.shape[1]):
        previous = list(d[:, a]) if previous is None else [d[r, a] + w * previous[r] for r in range(d.shape[0])]
        scores[a] = previous
    return scores, {a: int(np.argmin(d[:, a])) for a in range(d.shape[1])}


def smallest(values, n):
    """The n smallest values (ties: lowest reference) and their references; +inf and -1 past the finite ones."""
    order = sorted((v, r) for r, v in enumerate(values) if np.isfinite(v))[:n]
    order += [(np.inf, -1)] * (n - len(order))
    return [v for v, _ in order], [r for _, r in order]


@pytest.mark.parametrize(("cls", "naive"), [(Centred, naive_centred), (Smoothing, naive_smoothing)])
@pytest.mark.parametrize("block_queries", [None, 2, 5])
def test_a_matcher_that_is_not_seqslam_gets_its_candidates_and_labels_from_the_shared_code(cls, naive, block_queries):
    rng = np.random.default_rng(3)
    d = rng.integers(0, 4, size=(9, 14)).astype(np.float32)  # few values: many ties
    seq_len, tolerance, n, weight = 3, 1, 12, 0.25
    matcher = cls(seq_len, ToySettings(weight))
    features = query_features(d, seq_len, tolerance, block_queries=block_queries, matcher=matcher, n_candidates=n)
    scores, match = naive(d.astype(np.float64), weight)
    # the queries the matcher evaluates that have a window of L columns: the attributes need it
    queries = [a for a in sorted(scores) if a >= seq_len - 1]
    assert features.queries.tolist() == queries
    assert features.sequence_match.tolist() == [match[a] for a in queries]
    assert features.sequence_distance.tolist() == [scores[a][match[a]] for a in queries]
    expected = [smallest(scores[a], n) for a in queries]
    assert features.sequence_candidates.tolist() == [values for values, _ in expected]
    assert features.sequence_candidate_references.tolist() == [references for _, references in expected]
    assert features.sequence_max == max(v for a in queries for v in scores[a] if np.isfinite(v))
    single = [int(np.argmin(d[:, a])) for a in queries]
    single_correct = [abs(r - a) <= tolerance for r, a in zip(single, queries, strict=True)]
    sequence_correct = [abs(match[a] - a) <= tolerance for a in queries]
    assert features.labels.tolist() == [
        (0 if s else 1) if c else (2 if s else 3) for c, s in zip(single_correct, sequence_correct, strict=True)]
    assert features.all_single_correct.tolist() == [abs(int(np.argmin(d[:, a])) - a) <= tolerance
                                                    for a in range(d.shape[1])]
    # the attributes describe the window of D, whatever the matcher: the fixed diagonals' (method §14)
    fixed = query_features(d, seq_len, tolerance)
    rows = np.searchsorted(fixed.queries, features.queries)
    assert np.array_equal(features.attributes, fixed.attributes[rows])
    assert np.array_equal(features.rank_references, fixed.rank_references[rows])
    # recall@N ranks the matcher's match first, then the other references by finite score, stably (method §14):
    # Smoothing's match is the single-frame one, not its lowest score
    found = retrieval(d, seq_len, tolerance, block_queries, matcher)
    assert found.queries.tolist() == queries
    for n_row, a in enumerate(queries):
        order = [match[a], *(r for _, r in sorted((v, r) for r, v in enumerate(scores[a])
                                                   if np.isfinite(v) and r != match[a]))]
        ranks = [i for i, r in enumerate(order) if abs(r - a) <= tolerance]
        assert found.sequence_rank[n_row] == (ranks[0] if ranks else np.iinfo(np.int64).max)


class Offset(Matcher):
    """s_a[r] = D[r, a] - max(D) over the whole split: a matcher whose numbers depend on the whole split, which its
    ``prepare`` reads before the first block (the hook openseqslam's global minimum needs)."""

    name = "offset_toy"
    Settings = ToySettings
    description = "the column minus the split's largest value (a test's matcher)"

    @property
    def lookback(self):
        return 0

    def check(self, shape, name="distance matrix"):
        pass

    def prepare(self, matrix):
        return float(np.max(read_columns(matrix, 0, matrix.shape[1])))

    def block(self, columns, first_column, state):
        scores = columns.astype(np.float64) - state
        return MatchBlock(first_column + np.arange(len(columns)), scores, np.argmin(scores, axis=1)), state


@pytest.mark.parametrize("block_queries", [1, 3, None])
@pytest.mark.parametrize("in_file", [False, True])
def test_match_blocks_starts_from_the_matchers_prepare_over_the_whole_split(tmp_path, block_queries, in_file):
    d = np.arange(24, dtype=np.float64).reshape(4, 6) % 7  # largest value 6, not in the first column
    expected = [[d[r, a] - 6.0 for r in range(4)] for a in range(6)]
    with h5py.File(tmp_path / "d.h5", "w") as out:
        out["d"] = d
    with h5py.File(tmp_path / "d.h5", "r") as source:
        matrix = source["d"] if in_file else d
        blocks = [found for found, _, _ in match_blocks(Offset(2, ToySettings()), matrix, block_queries)]
        assert np.concatenate([b.scores for b in blocks]).tolist() == expected
        assert np.concatenate([b.queries for b in blocks]).tolist() == list(range(6))


def test_prepare_defaults_to_the_initial_state():
    assert Centred(3, ToySettings()).prepare(np.ones((3, 3))) is None
    assert Smoothing(3, ToySettings()).prepare(np.ones((3, 3))).shape == (0,)


def test_a_matcher_that_evaluates_no_query_with_a_window_is_named():
    # queries 1 .. 2 evaluated, none of them with a window of L = 4 columns: a degenerate split, said in words
    with pytest.raises(ValueError, match=r"the matcher 'centred_toy' evaluates no query of this 6 x 4 matrix that has "
                                         r"a window of L = 4 columns \(queries 3 on\)"):
        query_features(np.ones((6, 4)), 4, matcher=Centred(4, ToySettings()))


def test_seqslams_scores_are_the_trajectory_sums_with_inf_where_none_ends():
    rng = np.random.default_rng(4)
    d = rng.random((12, 8))
    matcher = seqslam(0.5, 2.0).build(3)
    assert isinstance(matcher, SeqSLAM) and matcher.attribute_velocities == (0.5, 2.0)
    found, state = matcher.block(d.T, 0, None)
    assert state is None and found.queries.tolist() == list(range(2, 8))
    for n, a in enumerate(range(2, 8)):
        for r in range(12):
            sums = []
            for v in (0.5, 2.0):  # o_k(v) = floor(v (L-1-k) + 0.5)
                rows = [r - int(np.floor(v * (2 - k) + 0.5)) for k in range(3)]
                if min(rows) >= 0:
                    sums.append(0.0 + d[rows[0], a - 2] + d[rows[1], a - 1] + d[rows[2], a])
            assert found.scores[n, r] == (min(sums) if sums else np.inf)
    assert np.array_equal(found.match, np.argmin(found.scores, axis=1))


# --- the registry and the spec ----------------------------------------------------------------------------------


@pytest.fixture
def installed(monkeypatch):
    """``centred_toy`` and ``smoothing_toy`` registered as an installed package's entry points would register them."""
    points = [SimpleNamespace(name=cls.name, load=lambda cls=cls: cls) for cls in (Centred, Smoothing)]
    monkeypatch.setattr("vpr_smr.core.registry.entry_points",
                        lambda group: points if group == registry.ENTRY_POINT_GROUP else [])


def test_an_unknown_matcher_is_refused_listing_the_available_ones(installed):
    known = sorted({*registry.MATCHERS, "centred_toy", "smoothing_toy"})  # the built-in ones and the two installed
    assert available_matchers() == known
    assert matcher_class("seqslam") is SeqSLAM and matcher_class("centred_toy") is Centred
    with pytest.raises(ValueError, match=r"unknown sequence matcher 'seqslm' \(did you mean 'seqslam'\?\); "
                                         r"available: " + re.escape(", ".join(known)) +
                                         r" \(a package adds one through the entry point group "
                                         r"vpr_smr.matchers\)"):
        MatcherSpec.of("seqslm")


def test_a_spec_names_the_matcher_and_its_settings(installed):
    assert MatcherSpec.of() == seqslam() == seqslam(1.0) and str(seqslam()) == "seqslam (velocities [1.0])"
    # seqslam's velocities as a set: another order is the same matcher, and the same hash
    assert seqslam(2.0, 0.5, 1.0) == seqslam(0.5, 1.0, 2.0) and hash(seqslam(2.0, 0.5)) == hash(seqslam(0.5, 2.0))
    toy = MatcherSpec.of("centred_toy", {"weight": 0.25})
    assert toy.provenance() == {"name": "centred_toy", "settings": {"weight": 0.25}}
    assert MatcherSpec.from_provenance(toy.provenance(), "f.h5") == toy != MatcherSpec.of("centred_toy")
    assert isinstance(toy.build(3), Centred) and toy.build(3).settings == ToySettings(0.25)
    with pytest.raises(ValueError, match="sequence_matching.weight: weight of the neighbouring columns; must be > 0"):
        MatcherSpec.of("centred_toy", {"weight": 0})
    with pytest.raises(ValueError, match=r"sequence_matching.velocity: unexpected setting 'velocity'"):
        MatcherSpec.of("seqslam", {"velocity": [1.0]})


def test_a_predictor_of_another_matcher_is_refused_naming_both(installed):
    toy = MatcherSpec.of("centred_toy", {"weight": 0.25})
    predictor = SimpleNamespace(path_="p.h5", matching_=Matching.of(seqslam(0.8, 1.0)))
    with pytest.raises(ValueError) as error:
        check_matching(predictor, Matching.of(toy), "these matrices")
    assert str(error.value) == (
        "p.h5 was trained on attributes of the matcher seqslam (velocities [0.8, 1.0]), ground truth from frame "
        "indices within a tolerance, but it is applied to these matrices, of the matcher centred_toy (weight 0.25), "
        "ground truth from frame indices within a tolerance: give the predictor trained with this matcher (the same "
        "matcher and settings, and positions with a radius or not), or train one for it")
    check_matching(predictor, Matching.of(seqslam(1.0, 0.8)), "these matrices")  # its own: accepted


def test_the_live_matcher_runs_a_causal_matcher_frame_by_frame_as_the_batch(installed):
    d = np.random.default_rng(6).integers(0, 4, size=(10, 16)).astype(np.float64)
    spec = MatcherSpec.of("smoothing_toy", {"weight": 0.5})
    batch = query_features(d, 3, matcher=spec)
    live = LiveMatcher(3, matcher=spec)
    results = [live.step_distances(d[:, a]) for a in range(16)]
    assert results[:2] == [None, None]
    assert [r.sequence_match for r in results[2:]] == batch.sequence_match.tolist()
    assert [r.sequence_distance for r in results[2:]] == batch.sequence_distance.tolist()  # the state carried
    assert np.array_equal([r.attributes for r in results[2:]], batch.attributes)
    with pytest.raises(ValueError, match=r"the matcher 'centred_toy' reads 1 columns after its query \(a centred "
                                         r"window\): a LiveMatcher has no frame to come"):
        LiveMatcher(3, matcher=MatcherSpec.of("centred_toy"))


# --- files of vpr-smr 0.9: no "matcher" record ------------------------------------------------------------------


def test_an_attributes_file_of_0_9_is_read_as_seqslam_with_its_velocities(tmp_path):
    d = np.random.default_rng(5).random((20, 20))
    features = query_features(d, 3, 2, matcher=seqslam(0.5, 1.0))
    write_features(tmp_path / "old.h5", features, {"seq_len": 3, "tolerance": 2, "velocities": [1.0, 0.5]})
    write_features(tmp_path / "fixed.h5", query_features(d, 3, 2), {"seq_len": 3, "tolerance": 2})
    assert "matcher" not in read_provenance(tmp_path / "old.h5")  # written the old way
    assert Matching.stored(tmp_path / "old.h5") == Matching.of(seqslam(0.5, 1.0))
    assert Matching.stored(tmp_path / "fixed.h5") == Matching.of(seqslam())  # no velocities: the fixed matcher
    check_matcher([tmp_path / "old.h5"], seqslam(1.0, 0.5), None)
    with pytest.raises(ValueError, match=r"old.h5 holds attributes of the matcher seqslam \(velocities \[0.5, 1.0\]\), "
                                         r"ground truth from frame indices within a tolerance, but this stage was "
                                         r"given the matcher seqslam \(velocities \[1.0\]\)"):
        check_matcher([tmp_path / "old.h5"], seqslam(), None)


def test_a_predictor_file_of_0_9_is_read_as_seqslam_with_its_velocities(tmp_path):
    rng = np.random.default_rng(0)
    model = SMRPredictor(hidden_layer_sizes=(4,), max_iter=5)
    with pytest.warns(Warning):  # too few iterations to converge: the weights do not matter here
        model.fit(rng.normal(size=(40, 4)), np.repeat(np.arange(4), 10))
    model.save(tmp_path / "old.h5")
    with h5py.File(tmp_path / "old.h5", "a") as f:  # the record as vpr-smr 0.9 wrote it
        f.attrs["matching"] = json.dumps({"velocities": [1.25, 0.8, 1.0], "ground_truth": "positions"})
    loaded = SMRPredictor.load(tmp_path / "old.h5")
    assert loaded.matching_ == Matching.of(seqslam(0.8, 1.0, 1.25), "positions")


def test_a_queries_csv_of_0_9_names_its_matcher_by_velocities(tmp_path):
    from vpr_smr.eval.report.inspector import read_queries

    header = ("split,query,single_match,single_distance,single_correct,sequence_match,sequence_distance,"
              "sequence_correct,true_reference,A1,A2,A3,A4,label,predicted_class,probability,kept,velocities")
    (tmp_path / "q.csv").write_text(f"{header}\ntest,2,2,0.5,1,2,1.5,1,2,0.1,0.2,0.3,0.4,0,,,,0.5 1\n")
    (row,) = read_queries(tmp_path / "q.csv")
    assert row.matcher == "seqslam (velocities [0.5, 1.0])"
