"""The sequence matcher's candidates for the training-free scorers (method §12): per query the n smallest S[r, a]
and the n smallest D[r, a] with their references, in ascending order, equal values lowest reference first, from
every implementation (the fixed matcher's numpy path and compiled kernel, velocity search's numpy twin and compiled
kernel) bit for bit, block-wise as whole, and without changing any number the matcher reported before."""

from dataclasses import fields

import h5py
import numpy as np
import pytest
from oracles import naive_end_sums, tied_matrix

from vpr_smr.eval.matching import matcher
from vpr_smr.eval.matching.attributes import (
    CANDIDATE_FIELDS,
    DEFAULT_CANDIDATES,
    AttributesJob,
    QueryFeatures,
    query_features,
    read_features,
)
from vpr_smr.eval.matching.attributes import main as attributes_main
from vpr_smr.eval.matching.matcher import SequenceMatcher
from vpr_smr.pipeline.stages.matching import ATTRIBUTES

pytest.importorskip("numba")

KEYS = ("sequence_candidates", "sequence_candidate_references", "single_candidates", "single_candidate_references")


def features(matrix, seq_len, velocities, n, kernel, **kwargs):
    previous, matcher.KERNEL = matcher.KERNEL, kernel
    try:
        return SequenceMatcher(seq_len, velocities).features(matrix, 4, n_candidates=n, **kwargs)
    finally:
        matcher.KERNEL = previous


def naive_candidates(d, seq_len, velocities, n):
    """The n smallest S and D of every evaluated query by their definitions, padded with +inf and -1."""
    d = np.asarray(d, dtype=np.float64)
    out = {key: [] for key in KEYS}
    for a in range(seq_len - 1, d.shape[1]):
        sums = naive_end_sums(d, a, seq_len, velocities)
        for values, names in ((sums, KEYS[:2]), ({r: float(d[r, a]) for r in range(d.shape[0])}, KEYS[2:])):
            best = sorted(values, key=lambda r: (values[r], r))[:n]
            out[names[0]].append([values[r] for r in best] + [np.inf] * (n - len(best)))
            out[names[1]].append(best + [-1] * (n - len(best)))
    return {key: np.array(value, dtype=np.int64 if "references" in key else np.float64) for key, value in out.items()}


MATRICES = {
    "random float32": np.random.default_rng(1).random((80, 40), dtype=np.float32),
    "stopped train (ties)": tied_matrix(n_ref=90, n_query=40),
    "integers 0..2": np.random.default_rng(2).integers(0, 3, (40, 30)),
    "constant": np.full((30, 20), 2.0),
    "fewer references than candidates": np.random.default_rng(3).random((8, 20)),
}


@pytest.mark.parametrize("velocities", [(1.0,), (0.5, 1.0, 2.0)], ids=["fixed", "velocity search"])
@pytest.mark.parametrize("seq_len", [2, 5])
@pytest.mark.parametrize("name", list(MATRICES))
def test_candidates_equal_the_definition_on_every_path(name, seq_len, velocities):
    d = MATRICES[name]
    if d.shape[0] <= matcher.first_reference(seq_len, velocities):
        pytest.skip("too few references for the slowest trajectory")
    expected = naive_candidates(d, seq_len, velocities, 12)
    numpy_path = features(d, seq_len, velocities, 12, "numpy")
    compiled = features(d, seq_len, velocities, 12, "numba")
    for key in KEYS:
        np.testing.assert_array_equal(numpy_path[key], expected[key], err_msg=key)
        assert numpy_path[key].dtype == compiled[key].dtype == expected[key].dtype, key
        assert numpy_path[key].tobytes() == compiled[key].tobytes(), key
    # the first candidates are the matches and the sequence distance, bit for bit
    assert numpy_path["sequence_candidates"][:, 0].tobytes() == numpy_path["sequence_distance"].tobytes()
    assert np.array_equal(numpy_path["sequence_candidate_references"][:, 0], numpy_path["sequence_match"])
    assert np.array_equal(numpy_path["single_candidate_references"][:, 0], numpy_path["single_match"])


@pytest.mark.parametrize("kernel", ["numpy", "numba"])
@pytest.mark.parametrize("velocities", [(1.0,), (0.8, 1.0, 1.25)], ids=["fixed", "velocity search"])
def test_candidates_change_nothing_else_and_blocks_equal_the_whole(kernel, velocities):
    d = tied_matrix(n_ref=120, n_query=70)
    without = features(d, 4, velocities, 0, kernel)
    assert not set(KEYS) & set(without)  # none asked for: none computed
    whole = features(d, 4, velocities, 30, kernel)
    for key, value in without.items():
        assert whole[key].tobytes() == value.tobytes(), key
    for block in (1, 9, 67):
        blocked = features(d, 4, velocities, 30, kernel, block_queries=block)
        assert all(blocked[key].tobytes() == whole[key].tobytes() for key in whole), block


def test_a_lazy_matrix_gives_the_same_candidates(tmp_path):
    d = tied_matrix(n_ref=100, n_query=60)
    with h5py.File(tmp_path / "D.h5", "w") as f:
        f.create_dataset("distance_matrix", data=d, chunks=(32, 16))
    expected = features(d, 3, (1.0,), 12, "numpy")
    with h5py.File(tmp_path / "D.h5", "r") as f:
        for kernel in ("numpy", "numba"):
            got = features(f["distance_matrix"], 3, (1.0,), 12, kernel)
            assert all(got[key].tobytes() == expected[key].tobytes() for key in expected), kernel


def test_the_attributes_file_keeps_the_candidates_and_every_array_it_held(tmp_path):
    d = np.random.default_rng(7).random((50, 50)).astype(np.float32)
    np.save(tmp_path / "D.npy", d)
    attributes_main(AttributesJob(str(tmp_path / "D.npy"), 3, candidates=0, out=str(tmp_path / "none.h5")))
    attributes_main(AttributesJob(str(tmp_path / "D.npy"), 3, out=str(tmp_path / "kept.h5")))
    with h5py.File(tmp_path / "none.h5") as before, h5py.File(tmp_path / "kept.h5") as after:
        assert set(after) == set(before) | set(CANDIDATE_FIELDS)
        for name in before:  # every array a file held before the candidates existed, byte for byte
            assert before[name][()].tobytes() == after[name][()].tobytes(), name
        assert after.attrs["n_candidates"] == DEFAULT_CANDIDATES == 12 and "n_candidates" not in before.attrs
    old, new = read_features(tmp_path / "none.h5"), read_features(tmp_path / "kept.h5")
    assert old.n_candidates == 0 and all(getattr(old, name) is None for name in CANDIDATE_FIELDS)
    assert new.n_candidates == 12
    expected = query_features(d, 3, n_candidates=12, fingerprint=True)
    for field in fields(QueryFeatures):
        assert np.array_equal(getattr(new, field.name), getattr(expected, field.name)), field.name
    with pytest.raises(ValueError, match=r"attributes\.candidates: .*must be >= 0, got -1"):
        ATTRIBUTES(distances=str(tmp_path / "D.npy"), seq_len=3, candidates=-1, out=str(tmp_path / "bad.h5"))
