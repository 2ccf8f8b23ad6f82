"""A predictor file records its length, methods and training matrices, whoever wrote it, and every consumer refuses
another length or a matrix it was trained on (or an overlapping block) unless the overlap is allowed.

The matrices are a place-recognition-like matrix of this file's own seed (a band of small distances around the
diagonal under strong noise), cut into blocks; no other test uses them."""

import hashlib
import json
import logging
import struct

import h5py
import numpy as np
import pytest

from vpr_smr import api as smr
from vpr_smr.eval.matching import fingerprint
from vpr_smr.eval.matching.attributes import MATRIX_PRINT
from vpr_smr.eval.matching.fingerprint import PATCH, matrix_print, patch_hashes
from vpr_smr.eval.matching.live import LiveMatcher
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.leakage import MATRICES, TRAINED_ON, FrameRange, SplitLeakError
from vpr_smr.pipeline.cli import main as cli

MASK = 2**64 - 1
SMALL = {"hidden_layer_sizes": [8], "max_iter": 60}  # a small network: the records matter here, not its F1


def place_matrix(n: int = 240, seed: int = 4417) -> np.ndarray:
    rng = np.random.default_rng(seed)
    r, q = np.arange(n)[:, None], np.arange(n)[None, :]
    return np.minimum(np.abs(r - q), 12) / 12 + rng.uniform(0, 1.6, (n, n))


D = place_matrix()
TRAIN, DISJOINT, OVERLAPPING = D[:120, :120], D[120:, 120:], D[80:200, 80:200]  # 40 x 40 entries shared


# --- the fingerprint, against a naive one -------------------------------------------------------------------------


def naive_mix(x: int) -> int:
    x ^= x >> 30
    x = (x * 0xBF58476D1CE4E5B9) & MASK
    x ^= x >> 27
    x = (x * 0x94D049BB133111EB) & MASK
    return x ^ (x >> 31)


def naive_hashes(matrix: np.ndarray) -> list[int]:
    """Every non-constant patch's hash, one patch at a time: sum of w[a] w[b] mix(bits) modulo 2**64."""
    weights = [int(w) for w in fingerprint._WEIGHTS]
    bits = [[naive_mix(struct.unpack("<Q", struct.pack("<d", float(v) + 0.0))[0]) for v in row] for row in matrix]
    out = []
    for i in range(matrix.shape[0] - PATCH + 1):
        for j in range(matrix.shape[1] - PATCH + 1):
            patch = [matrix[i + a, j + b] for a in range(PATCH) for b in range(PATCH)]
            if all(v == patch[0] for v in patch):
                continue
            out.append(sum(weights[a] * weights[b] * bits[i + a][j + b]
                           for a in range(PATCH) for b in range(PATCH)) & MASK)
    return out


def test_patch_hashes_and_the_print_equal_a_naive_computation(monkeypatch):
    block = np.round(place_matrix(9, 7)[:, :7] * 4) / 4  # few distinct values: equal patches hash equally
    block[:5, :5] = 2.0  # a constant corner: its 4 patches are skipped
    block[6, 6] = -0.0  # the same value as 0.0
    assert sorted(patch_hashes(block).tolist()) == sorted(naive_hashes(block))
    monkeypatch.setattr(fingerprint, "BLOCK_VALUES", 20)  # column blocks of 4 columns: patches straddle them
    found = matrix_print(block, max_anchors=8)
    patches = (9 - PATCH + 1) * (7 - PATCH + 1)  # 24 patches, 8 anchors wanted: every 4th hash (a power of two)
    assert found.modulus == 4 and found.shape == (9, 7)
    assert found.anchors == tuple(sorted({h for h in naive_hashes(block) if h % 4 == 0}))
    assert len(naive_hashes(block)) == patches - 4
    assert found.sha256 == hashlib.sha256(b"9x7:" + block.astype(np.float64).tobytes(order="F")).hexdigest()
    assert matrix_print(block.T, max_anchors=8).anchors == found.anchors  # read with --transpose: the same anchors


def test_overlapping_blocks_share_anchors_and_disjoint_ones_none():
    trained = matrix_print(TRAIN)
    assert trained.shared(matrix_print(TRAIN.copy())) == len(trained.anchors) > 1000
    # 40 x 40 shared entries hold 37 x 37 patches; a 120 x 120 matrix keeps every patch as an anchor (modulus 1)
    assert trained.modulus == 1
    assert trained.shared(matrix_print(OVERLAPPING)) == len(set(naive_hashes(D[80:120, 80:120]))) == 37 * 37
    assert trained.shared(matrix_print(DISJOINT)) == 0
    assert trained.shared(matrix_print(D[:120, 120:])) == 0  # the same references, other queries: no entry shared
    assert len(fingerprint.found_anchors(OVERLAPPING, np.asarray(trained.anchors, np.uint64))) == sum(
        1 for h in set(naive_hashes(D[80:120, 80:120])) if h % trained.modulus == 0)


# --- what a predictor file records --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def api_predictor(tmp_path_factory):
    """A predictor trained at L = 6 on TRAIN with the Python API and saved with save_predictor."""
    folder = tmp_path_factory.mktemp("provenance")
    for name, matrix in (("train", TRAIN), ("disjoint", DISJOINT), ("overlapping", OVERLAPPING), ("all", D)):
        np.save(folder / f"{name}.npy", matrix)
    predictor = smr.train(smr.attributes(TRAIN, 6), settings=SMALL)
    smr.save_predictor(predictor, folder / "p6.h5", methods=["noise"])
    return folder, predictor


def test_save_predictor_records_length_methods_and_matrix(api_predictor):
    folder, predictor = api_predictor
    loaded = smr.load_predictor(folder / "p6.h5")
    assert loaded.seq_len_ == 6 and loaded.training_.methods == ("noise",)
    (trained,) = loaded.training_.matrices
    assert trained.shape == (120, 120)
    assert trained.sha256 == hashlib.sha256(b"120x120:" + TRAIN.tobytes(order="F")).hexdigest()
    assert trained == predictor.training_.matrices[0]


def test_save_predictor_needs_a_length_it_cannot_know(tmp_path):
    features = smr.attributes(TRAIN, 6)
    by_hand = SMRPredictor(hidden_layer_sizes=(8,), max_iter=60).fit(features.attributes[:, 0], features.labels)
    with pytest.raises(ValueError, match=r"seq_len: the predictor does not record .*\(\.\.\., seq_len=L\)"):
        smr.save_predictor(by_hand, tmp_path / "p.h5")
    assert not (tmp_path / "p.h5").exists()
    smr.save_predictor(by_hand, tmp_path / "p.h5", seq_len=6)
    assert smr.load_predictor(tmp_path / "p.h5").seq_len_ == 6
    with pytest.raises(ValueError, match="trained on features of L = 6, not 4"):
        smr.save_predictor(smr.load_predictor(tmp_path / "p.h5"), tmp_path / "q.h5", seq_len=4)


# --- every consumer refuses another length -------------------------------------------------------------------------


def test_metrics_refuses_a_predictor_of_another_length(api_predictor, capsys):
    folder, _ = api_predictor
    code = cli(["metrics", "--distances", str(folder / "disjoint.npy"), "--seq-len", "4", "--predictor",
                str(folder / "p6.h5"), "--out", str(folder / "m.json")])
    error = capsys.readouterr().err
    assert code == 2 and not (folder / "m.json").exists()
    assert "p6.h5 was trained at sequence length 6, but it is applied at L = 4 (--seq-len 4)" in error
    assert "give the predictor trained at L = 4, or --seq-len 6" in error


def test_the_api_and_live_matcher_refuse_another_length(api_predictor):
    folder, predictor = api_predictor
    loaded = smr.load_predictor(folder / "p6.h5")
    for model in (predictor, loaded):
        with pytest.raises(ValueError, match="trained at sequence length 6, but it is applied at L = 4"):
            smr.metrics(DISJOINT, 4, predictor=model)
        with pytest.raises(ValueError, match="trained at sequence length 6, but it is applied at L = 4"):
            smr.predict(model, smr.attributes(DISJOINT, 4))
    with pytest.raises(ValueError, match="trained at sequence length 6, but it is applied at L = 4"):
        smr.evaluate(smr.attributes(DISJOINT, 4), [loaded])
    with pytest.raises(ValueError, match="p6.h5 was trained at sequence length 6, but it is applied at L = 4"):
        LiveMatcher(4, predictor=loaded)


def test_a_file_without_a_length_is_applied_with_a_warning(api_predictor, tmp_path, caplog):
    folder, _ = api_predictor
    old = tmp_path / "old.h5"
    old.write_bytes((folder / "p6.h5").read_bytes())
    with h5py.File(old, "r+") as f:  # what save_predictor of 0.14 wrote: no length
        del f.attrs["seq_len"]
    with caplog.at_level(logging.WARNING, logger="vpr_smr"):
        smr.metrics(DISJOINT, 4, predictor=smr.load_predictor(old))
    assert f"{old} records no sequence length" in caplog.text and "save_predictor(..., seq_len=L)" in caplog.text


def test_the_matcher_is_still_checked(api_predictor, capsys):
    folder, _ = api_predictor
    code = cli(["metrics", "--distances", str(folder / "disjoint.npy"), "--seq-len", "6", "--matcher",
                "bayes_filter", "--predictor", str(folder / "p6.h5"), "--out", str(folder / "m.json")])
    assert code == 2 and "was trained on attributes of the matcher seqslam" in capsys.readouterr().err


# --- and the matrices it was trained on ----------------------------------------------------------------------------


@pytest.mark.parametrize("scored, words", [("train", "and {path} is that matrix"),
                                           ("all", "which shares entries with {path}"),
                                           ("overlapping", "which shares entries with {path}")])
def test_metrics_refuses_its_training_matrix_and_overlapping_blocks(api_predictor, capsys, caplog, scored, words):
    folder, _ = api_predictor
    path = folder / f"{scored}.npy"
    options = ["metrics", "--distances", str(path), "--seq-len", "6", "--predictor", str(folder / "p6.h5"), "--out",
               str(folder / f"{scored}.json")]
    assert cli(options) == 2
    error = capsys.readouterr().err
    assert "was trained on a 120 x 120 matrix" in error and words.format(path=path) in error
    assert "--allow-split-overlap" in error and not (folder / f"{scored}.json").exists()
    with caplog.at_level(logging.WARNING, logger="vpr_smr"):
        assert cli([*options, "--allow-split-overlap"]) == 0
    assert "its scores there are measured on its own training data" in caplog.text


def test_disjoint_blocks_of_the_same_matrix_are_scored(api_predictor):
    folder, _ = api_predictor
    assert cli(["metrics", "--distances", str(folder / "disjoint.npy"), "--seq-len", "6", "--predictor",
                str(folder / "p6.h5"), "--out", str(folder / "d.json")]) == 0
    smr.metrics(DISJOINT, 6, predictor=smr.load_predictor(folder / "p6.h5"))


def test_the_api_refuses_its_training_matrix(api_predictor):
    _, predictor = api_predictor
    with pytest.raises(SplitLeakError, match="shares entries with distances"):
        smr.metrics(OVERLAPPING, 6, predictor=predictor)
    with pytest.raises(SplitLeakError, match="and features is that matrix"):
        smr.predict(predictor, smr.attributes(TRAIN, 6))
    overlapping = smr.attributes(OVERLAPPING, 6)
    for call in (lambda allow: smr.evaluate(overlapping, [predictor], allow_split_overlap=allow),
                 lambda allow: smr.baselines(overlapping, predictors=[predictor], allow_split_overlap=allow)):
        with pytest.raises(SplitLeakError, match="shares entries with features"):
            call(False)
        call(True)


def test_cli_training_records_the_matrices_and_evaluate_refuses_them(tmp_path, capsys):
    np.save(tmp_path / "train.npy", TRAIN)
    np.save(tmp_path / "over.npy", OVERLAPPING)
    for name in ("train", "over"):
        assert cli(["attributes", "--distances", str(tmp_path / f"{name}.npy"), "--seq-len", "6", "--out",
                    str(tmp_path / f"{name}.h5")]) == 0
    assert cli(["train", "--dataset", "noise", "--seq-len", "6", "--train", str(tmp_path / "train.h5"),
                "--predictor", '{"hidden_layer_sizes": [8], "max_iter": 60}', "--out", str(tmp_path / "L6.h5")]) == 0
    loaded = smr.load_predictor(tmp_path / "L6.h5")
    assert loaded.seq_len_ == 6 and loaded.training_.methods == ("train.h5",)
    assert loaded.training_.matrices == (matrix_print(TRAIN),)
    options = ["evaluate", "--dataset", "noise", "--method", "m", "--seq-len", "6", "--attributes",
               f"test={tmp_path / 'over.h5'}", "--predictors", str(tmp_path / "L6.h5"), "--out",
               str(tmp_path / "ev.json")]
    capsys.readouterr()
    assert cli(options) == 2
    assert f"shares entries with {tmp_path / 'over.h5'}" in capsys.readouterr().err
    assert not (tmp_path / "ev.json").exists()
    assert cli([*options, "--allow-split-overlap"]) == 0


def test_train_refuses_features_of_two_lengths():
    with pytest.raises(ValueError, match=r"sequence lengths \[4, 6\]: a predictor learns the matches of one length"):
        smr.train([smr.attributes(TRAIN, 6), smr.attributes(DISJOINT, 4)], settings=SMALL)


# --- where no print and no frame range can tell, a warning says so ------------------------------------------------

UNCHECKED = "cannot be checked"


def _copy(source, target, drop=(), attrs=None):
    """``source`` copied to ``target`` without the datasets or groups ``drop``, with the attributes ``attrs``."""
    target.write_bytes(source.read_bytes())
    with h5py.File(target, "r+") as f:
        for name in drop:
            del f[name]
        f.attrs.update(attrs or {})
    return target


@pytest.fixture(scope="module")
def unprinted(api_predictor):
    """p6.h5 as 0.14 wrote it (no training matrices), the same with the frames of split 'train' of a dataset 'd'
    (frames 0-119, as the workflow records them), and DISJOINT's attributes, with the frames 120-239 of 'd'."""
    folder, _ = api_predictor
    old = _copy(folder / "p6.h5", folder / "old.h5", drop=[MATRICES])
    framed = _copy(old, folder / "framed.h5",
                   attrs={TRAINED_ON: json.dumps([FrameRange("d", "train", 0, 120).to_json()])})
    assert cli(["attributes", "--distances", str(folder / "disjoint.npy"), "--seq-len", "6", "--out",
                str(folder / "disjoint.h5")]) == 0
    test = _copy(folder / "disjoint.h5", folder / "test.h5",
                 attrs={"dataset": "d", "split": "test", "split_range": json.dumps([120, 240])})
    return folder, old, framed, test


def _warnings(caplog, options):
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="vpr_smr"):
        assert cli(options) == 0
    return [r.getMessage() for r in caplog.records if UNCHECKED in r.getMessage()]


def test_a_predictor_without_prints_scored_on_a_users_matrix_warns_once(unprinted, caplog):
    folder, old, _, _ = unprinted
    matrix = folder / "disjoint.npy"
    (said,) = _warnings(caplog, ["metrics", "--distances", str(matrix), "--seq-len", "6", "--predictor", str(old),
                                 "--out", str(folder / "old.json")])
    assert said.startswith(f"{matrix}: whether it shares entries with the matrices predictor {old} was trained on")
    assert f"predictor {old} records no print of them" in said
    assert said.endswith("fix: train the predictor again with this version")


def test_attributes_without_a_print_warn_and_say_to_compute_them_again(unprinted, caplog):
    folder, _, _, _ = unprinted
    bare = _copy(folder / "disjoint.h5", folder / "bare.h5", drop=[MATRIX_PRINT])  # 0.14's attributes
    (said,) = _warnings(caplog, ["evaluate", "--dataset", "noise", "--method", "m", "--seq-len", "6", "--attributes",
                                 f"test={bare}", "--predictors", str(folder / "p6.h5"), "--out",
                                 str(folder / "bare.json")])
    assert said.startswith(f"{bare}: ") and "it records no print of its matrix" in said
    assert said.endswith("fix: compute its attributes again with this version")


def test_frame_ranges_on_both_sides_check_it_without_a_word(unprinted, caplog):
    folder, old, framed, test = unprinted
    options = ["evaluate", "--dataset", "d", "--method", "m", "--seq-len", "6", "--attributes", f"test={test}",
               "--out", str(folder / "ev.json"), "--predictors"]
    assert _warnings(caplog, [*options, str(framed)]) == []  # the workflow's files: the frames tell
    # the frames of one side alone tell nothing: the predictor without frames warns on the same file
    (said,) = _warnings(caplog, [*options, str(old)])
    assert said.startswith(f"{test}: ")
