"""AP-GeM backend and the conversion of the official pickle (with its scikit-learn 0.20 PCA objects)."""

from __future__ import annotations

import collections
import hashlib
import io
import json
import os
import pickle
import sys
import types
from pathlib import Path

import numpy as np
import pytest
import torch
from helpers import TESTS

from vpr_smr.descriptors import CheckpointError, backend_class
from vpr_smr.descriptors.apgem import APGeM, GeM
from vpr_smr.descriptors.convert import PCAStandIn, RestrictedUnpickler, convert_apgem
from vpr_smr.descriptors.extract import check_checkpoint

KEYS = TESTS / "data" / "keys"
OPTIONS = {"arch": "resnet101_rmac", "out_dim": 2048, "pooling": "gem", "gemp": 3, "dropout_p": None}

torch.set_num_threads(1)


def test_registry_resolves_apgem() -> None:
    assert backend_class("apgem") is APGeM


def test_state_dict_matches_official_keys() -> None:
    with torch.device("meta"):
        backend = APGeM({"device": "cpu"})
    ours = {k: list(v.shape) for k, v in backend.model.state_dict().items()}
    assert ours == json.loads((KEYS / "apgem_resnet101.json").read_text())


def test_gem_matches_numpy() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(1.0, 1.0, (2, 3, 4, 5))  # some values are negative: GeM clamps them at eps
    gem = GeM(p=3.0).double()
    with torch.no_grad():
        gem.p.fill_(2.5)
        out = gem(torch.from_numpy(x)).numpy()
    expected = (np.maximum(x, 1e-6) ** 2.5).mean(axis=(2, 3)) ** (1 / 2.5)
    np.testing.assert_allclose(out, expected, rtol=1e-12)


def test_preprocess_full_size_and_max_size() -> None:
    with torch.device("meta"):
        backend = APGeM({"device": "cpu"})
    image = np.full((30, 40, 3), 255, dtype=np.uint8)
    tensor = backend.preprocess(image)
    assert tensor.shape == (3, 30, 40)
    expected = (1 - torch.tensor([0.485, 0.456, 0.406])) / torch.tensor([0.229, 0.224, 0.225])
    torch.testing.assert_close(tensor[:, 0, 0], expected)
    backend.conf["max_size"] = 20
    assert backend.preprocess(image).shape == (3, 15, 20)
    with torch.device("meta"):  # VPR-methods-evaluation also feeds full-size, ImageNet-normalised images
        harness = APGeM({"device": "cpu", "preprocessing": "vpr-methods-evaluation"})
    assert torch.equal(harness.preprocess(image), tensor)


class _OldPCA:
    """Stands for scikit-learn 0.20's PCA when writing an official-like pickle."""


_OldPCA.__module__, _OldPCA.__name__, _OldPCA.__qualname__ = "sklearn.decomposition.pca", "PCA", "PCA"


def write_official_like(path: Path, state_dict: dict[str, torch.Tensor], pca: dict, monkeypatch) -> None:
    """``torch.save`` legacy file shaped like ``Resnet-101-AP-GeM.pt``: DataParallel keys, a PCA object."""
    module = types.ModuleType("sklearn.decomposition.pca")
    module.PCA = _OldPCA
    monkeypatch.setitem(sys.modules, "sklearn.decomposition.pca", module)
    whitening = _OldPCA()
    whitening.__dict__.update(pca, n_components=len(pca["components_"]), copy=True, svd_solver="auto",
                              noise_variance_=np.float64(0.01), n_samples_=np.int64(5000),
                              _sklearn_version="0.20.3")
    checkpoint = {
        "model_options": OPTIONS,
        "state_dict": collections.OrderedDict(("module." + k, v) for k, v in state_dict.items()),
        "pca": {"Landmarks_clean": whitening},
        "preprocess": {"mean": [0.485, 0.456, 0.406], "std": [0.229, 0.224, 0.225], "input_size": 224},
        "epoch": 40,
    }
    # The 2019 release predates torch's zip format.
    torch.save(checkpoint, path, _use_new_zipfile_serialization=False)
    # numpy 1.x (2019) wrote numpy.core.multiarray; the pickle text names the module, so rewrite it.
    path.write_bytes(path.read_bytes().replace(b"numpy._core.multiarray", b"numpy.core.multiarray"))


def official_whitening(x: np.ndarray, pca: dict, whitenp: float) -> np.ndarray:
    """dirtorch ``whiten_features`` (use_sklearn=True, whiten=True), written out in numpy."""
    white = (x.astype(np.float64) - pca["mean_"]) @ pca["components_"].T
    white /= np.power(pca["explained_variance_"], whitenp)
    return white / np.linalg.norm(white, axis=1, keepdims=True)


def test_official_pickle_round_trip(tmp_path: Path, monkeypatch) -> None:
    torch.manual_seed(0)
    source = APGeM({"device": "cpu"})
    with torch.no_grad():
        source.model.adpool.p.fill_(2.8)
    rng = np.random.default_rng(0)
    pca = {
        "mean_": rng.normal(0, 0.01, 2048),
        "components_": np.linalg.qr(rng.normal(size=(2048, 16)))[0].T,  # 16 orthonormal rows
        "explained_variance_": rng.uniform(1e-4, 1e-2, 16),
        "whiten": True,
    }
    official = tmp_path / "Resnet-101-AP-GeM.pt"
    write_official_like(official, source.model.state_dict(), pca, monkeypatch)
    monkeypatch.delitem(sys.modules, "sklearn.decomposition.pca")

    with pytest.raises(CheckpointError, match="convert_apgem"):
        source.load(official)  # the raw pickle is refused by weights_only, with a pointer to the converter

    converted = convert_apgem(official, tmp_path / "apgem.pt")
    data = torch.load(converted, weights_only=True)
    assert data["model_options"] == OPTIONS and not any(k.startswith("module.") for k in data["state_dict"])
    assert data["whitening"]["Landmarks_clean"]["components"].dtype == torch.float64

    # The configuration check: same file, strict keys, whitening found, nothing computed.
    digest = check_checkpoint({"backend": "apgem", "checkpoint": str(converted), "whiten": "Landmarks_clean"})
    assert digest == hashlib.sha256(converted.read_bytes()).hexdigest()

    target = APGeM({"device": "cpu"})
    target.load(converted)  # default whiten: auto -> the file's Landmarks_clean, as test_dir.py
    batch = torch.randn(2, 3, 64, 64)
    expected = source.forward(batch)  # source has no whitening: the 2048-d descriptor
    assert target.whitening_name == "Landmarks_clean"
    out = target.forward(batch)
    assert out.shape == (2, 16)
    np.testing.assert_allclose(out, official_whitening(expected, pca, 0.25), atol=1e-6)
    assert target.model.adpool.p.item() == pytest.approx(2.8)

    target.conf["whiten"] = None
    target.load(converted)
    np.testing.assert_allclose(target.forward(batch), expected, atol=1e-6)

    target.conf["whiten"] = "Paris"
    with pytest.raises(CheckpointError, match="Landmarks_clean"):
        target.load(converted)

    # A converted file without the whitening: auto leaves it off; asking for it by name is an error.
    del data["whitening"]["Landmarks_clean"]
    torch.save(data, tmp_path / "apgem-no-whitening.pt")
    target.conf["whiten"] = "auto"  # the default
    target.load(tmp_path / "apgem-no-whitening.pt")
    assert target.whitening_name is None and target.model.whitening is None
    np.testing.assert_allclose(target.forward(batch), expected, atol=1e-6)
    target.conf["whiten"] = "Landmarks_clean"
    with pytest.raises(CheckpointError, match=r"has no whitening 'Landmarks_clean' \(it has: none\)"):
        target.load(tmp_path / "apgem-no-whitening.pt")


def test_restricted_unpickler_allows_only_listed_globals(tmp_path: Path) -> None:
    unpickler = RestrictedUnpickler(io.BytesIO())
    assert unpickler.find_class("sklearn.decomposition.pca", "PCA") is PCAStandIn
    assert unpickler.find_class("sklearn.decomposition._pca", "PCA") is PCAStandIn
    for module in ("numpy.core.multiarray", "numpy._core.multiarray"):
        assert callable(unpickler.find_class(module, "_reconstruct"))
    with pytest.raises(pickle.UnpicklingError, match="builtins.eval"):
        unpickler.find_class("builtins", "eval")

    marker = tmp_path / "created-by-unpickling"

    class Payload:
        def __reduce__(self):
            return (os.makedirs, (str(marker),))

    path = tmp_path / "evil.pt"
    torch.save({"state_dict": {}, "payload": Payload()}, path, _use_new_zipfile_serialization=False)
    with pytest.raises(CheckpointError, match=r"refusing to unpickle global (os|posix)\.makedirs"):
        convert_apgem(path, tmp_path / "out.pt")
    assert not marker.exists() and not (tmp_path / "out.pt").exists()


def test_mismatched_file_names_the_keys(tmp_path: Path) -> None:
    path = tmp_path / "apgem.pt"
    state_dict = {"conv1.weight": torch.zeros(64, 3, 5, 5), "extra.weight": torch.zeros(1)}
    torch.save({"state_dict": state_dict}, path)
    with torch.device("meta"), pytest.raises(CheckpointError) as info:
        APGeM({"device": "cpu"}).load(path)
    message = str(info.value)
    assert str(path) in message and "Resnet-101-AP-GeM.pt" in message
    assert "unexpected keys:\n    extra.weight" in message
    assert "conv1.weight: file (64, 3, 5, 5), model (64, 3, 7, 7)" in message
    assert "missing keys" in message


def test_missing_and_wrong_inputs(tmp_path: Path) -> None:
    with pytest.raises(CheckpointError, match="not found"):
        convert_apgem(tmp_path / "absent.pt", tmp_path / "out.pt")
    not_torch = tmp_path / "Resnet-101-AP-GeM.pt"
    not_torch.write_bytes(b"garbage")
    with pytest.raises(CheckpointError, match="Resnet-101-AP-GeM.pt"):
        convert_apgem(not_torch, tmp_path / "out.pt")
    with torch.device("meta"), pytest.raises(CheckpointError, match="convert_apgem"):
        APGeM({"device": "cpu"}).load(None)
