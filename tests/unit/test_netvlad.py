"""NetVLAD backend: official key names, exact aggregation maths, preprocessing, loading of both releases."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from helpers import TESTS

from vpr_smr.descriptors import CheckpointError, backend_class
from vpr_smr.descriptors.netvlad import NetVLAD, NetVLADPool

KEYS = TESTS / "data" / "keys"

torch.set_num_threads(1)


def shapes(module: torch.nn.Module) -> dict[str, list[int]]:
    return {k: list(v.shape) for k, v in module.state_dict().items()}


def test_registry_resolves_netvlad() -> None:
    assert backend_class("netvlad") is NetVLAD


@pytest.mark.parametrize(
    ("conf", "official"),
    [({}, "netvlad_patchnetvlad_wpca4096.json"), ({"num_pcs": 0}, "netvlad_nanne.json")],
)
def test_state_dict_matches_official_keys(conf: dict, official: str) -> None:
    # Shapes only: the meta device skips allocating the 32768 x 4096 WPCA.
    with torch.device("meta"):
        backend = NetVLAD({**conf, "device": "cpu"})
    assert shapes(backend.model) == json.loads((KEYS / official).read_text())


def naive_netvlad(features: np.ndarray, weight: np.ndarray, centroids: np.ndarray) -> np.ndarray:
    """Loop NetVLAD of one image: ``features (D, H, W)``, ``weight (K, D)``, ``centroids (K, D)``."""
    _, height, width = features.shape
    local = [features[:, i, j] / np.linalg.norm(features[:, i, j])
             for i in range(height) for j in range(width)]
    vlad = np.zeros_like(centroids)
    for x in local:
        logits = weight @ x
        soft = np.exp(logits - logits.max())
        soft /= soft.sum()
        for k in range(len(centroids)):
            vlad[k] += soft[k] * (x - centroids[k])
    for k in range(len(centroids)):
        vlad[k] /= np.linalg.norm(vlad[k])
    vlad = vlad.reshape(-1)
    return vlad / np.linalg.norm(vlad)


def test_aggregation_matches_naive_loop() -> None:
    generator = torch.Generator().manual_seed(0)
    pool = NetVLADPool(num_clusters=3, dim=5).double()
    with torch.no_grad():
        pool.conv.weight.copy_(torch.randn(3, 5, 1, 1, generator=generator, dtype=torch.float64) * 3)
        pool.centroids.copy_(torch.randn(3, 5, generator=generator, dtype=torch.float64))
    features = torch.randn(2, 5, 3, 4, generator=generator, dtype=torch.float64)
    with torch.no_grad():
        out = pool(features).numpy()
    weight, centroids = pool.conv.weight[:, :, 0, 0].detach().numpy(), pool.centroids.detach().numpy()
    for n in range(2):
        np.testing.assert_allclose(out[n], naive_netvlad(features[n].numpy(), weight, centroids), atol=1e-12)


def test_encoder_is_vgg16_up_to_conv5_3() -> None:
    with torch.device("meta"):
        encoder = NetVLAD({"num_pcs": 0, "device": "cpu"}).model.encoder
    assert len(encoder) == 29
    last = encoder[-1]
    assert isinstance(last, torch.nn.Conv2d) and (last.in_channels, last.out_channels) == (512, 512)
    assert sum(isinstance(m, torch.nn.MaxPool2d) for m in encoder) == 4  # output stride 16


def test_preprocess_equals_official_transform() -> None:
    from PIL import Image
    from torchvision import transforms

    with torch.device("meta"):
        backend = NetVLAD({"image_size": [24, 32], "num_pcs": 0, "device": "cpu"})
    image = np.random.default_rng(0).integers(0, 256, (50, 70, 3), dtype=np.uint8)
    # Patch-NetVLAD's input_transform((H, W)) on the PIL image.
    official = transforms.Compose([
        transforms.Resize((24, 32)), transforms.ToTensor(),
        transforms.Normalize(mean=[0.485, 0.456, 0.406], std=[0.229, 0.224, 0.225]),
    ])(Image.fromarray(image))
    torch.testing.assert_close(backend.preprocess(image), official, rtol=0, atol=1e-6)
    backend.conf["image_size"] = None  # full size (Nanne's evaluation)
    assert backend.preprocess(image).shape == (3, 50, 70)


def small_source(num_clusters: int, num_pcs: int) -> NetVLAD:
    torch.manual_seed(1)
    source = NetVLAD({"num_clusters": num_clusters, "num_pcs": num_pcs, "image_size": None, "device": "cpu"})
    with torch.no_grad():
        source.model.pool.conv.weight.mul_(50)  # random weights give near-uniform assignments otherwise
    return source


def test_patchnetvlad_file_round_trip(tmp_path: Path) -> None:
    source = small_source(num_clusters=4, num_pcs=8)
    state_dict = source.model.state_dict()
    for key in ("WPCA.0.weight", "WPCA.0.bias"):
        state_dict[key] = state_dict[key].double()  # as in the released *_WPCA*.pth.tar (from add_pca.py)
    path = tmp_path / "pitts_WPCA8.pth.tar"
    torch.save({"num_pcs": 8, "state_dict": state_dict}, path)

    target = NetVLAD({"num_clusters": 2, "num_pcs": 0, "image_size": None, "device": "cpu"})
    target.load(path)
    assert (target.conf["num_clusters"], target.conf["num_pcs"]) == (4, 8)  # read from the file's shapes
    assert target.model.WPCA[0].weight.dtype == torch.float32
    batch = torch.randn(2, 3, 48, 64)
    expected, out = source.forward(batch), target.forward(batch)
    assert out.shape == (2, 8)
    np.testing.assert_allclose(out, expected, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1, atol=1e-6)


@pytest.mark.parametrize("prefix", ["data_parallel", "leading"])
def test_nanne_file_round_trip(tmp_path: Path, prefix: str) -> None:
    source = small_source(num_clusters=4, num_pcs=0)
    if prefix == "data_parallel":  # main.py wraps encoder and pool in nn.DataParallel when nGPU > 1
        state_dict = {k.replace(".", ".module.", 1): v for k, v in source.model.state_dict().items()}
    else:
        state_dict = {"module." + k: v for k, v in source.model.state_dict().items()}
    checkpoint = {
        "epoch": 3, "state_dict": state_dict, "recalls": {1: np.float64(0.81), 5: np.float64(0.93)},
        "best_score": np.float64(0.93),
        "optimizer": {"state": {}, "param_groups": [{"lr": 1e-4, "params": [0]}]},
        "parallel": prefix == "data_parallel",
    }
    path = tmp_path / "checkpoint.pth.tar"
    torch.save(checkpoint, path, _use_new_zipfile_serialization=False)
    # Files of that time name numpy 1.x's module (numpy.core); keep both spellings covered.
    path.write_bytes(path.read_bytes().replace(b"numpy._core.multiarray", b"numpy.core.multiarray"))
    with pytest.raises(Exception, match="scalar"):
        torch.load(path, weights_only=True)  # the numpy scalars need the allow-list

    target = NetVLAD({"num_clusters": 4, "num_pcs": 16, "image_size": None, "device": "cpu"})
    target.load(path)
    assert target.model.WPCA is None and target.conf["num_pcs"] == 0
    batch = torch.randn(1, 3, 48, 48)
    out = target.forward(batch)
    assert out.shape == (1, 4 * 512)
    np.testing.assert_allclose(out, source.forward(batch), atol=1e-6)


def test_mismatched_file_names_the_keys(tmp_path: Path) -> None:
    path = tmp_path / "bad.pth.tar"
    torch.save({"state_dict": {
        "encoder.0.weight": torch.zeros(64, 3, 5, 5),  # wrong shape
        "pool.centroids": torch.zeros(4, 512),
        "pool.conv.weight": torch.zeros(4, 512, 1, 1),
        "pool.conv.bias": torch.zeros(4),  # vladv2 files: not this model
    }}, path)
    with torch.device("meta"), pytest.raises(CheckpointError) as info:
        NetVLAD({"num_pcs": 0, "device": "cpu"}).load(path)
    message = str(info.value)
    assert str(path) in message
    assert "missing keys" in message and "encoder.0.bias" in message
    assert "pool.conv.bias" in message
    assert "encoder.0.weight: file (64, 3, 5, 5), model (64, 3, 3, 3)" in message
    assert "pitts_WPCA4096.pth.tar" in message


def test_unreadable_and_missing_files(tmp_path: Path) -> None:
    with torch.device("meta"):
        backend = NetVLAD({"num_pcs": 0, "device": "cpu"})
    corrupt = tmp_path / "corrupt.pth.tar"
    corrupt.write_bytes(b"\x80\x02not a checkpoint")
    with pytest.raises(CheckpointError, match="corrupt.pth.tar"):
        backend.load(corrupt)
    with pytest.raises(CheckpointError, match="not found"):
        backend.load(tmp_path / "absent.pth.tar")
    with pytest.raises(CheckpointError, match="checkpoint.pth.tar"):
        backend.load(None)


def test_default_size_follows_the_loaded_file(tmp_path: Path) -> None:
    """Each file gets the input of its official evaluation: Patch-NetVLAD (WPCA) 480 x 640, Nanne full size."""
    image = np.random.default_rng(3).integers(0, 256, (50, 70, 3), dtype=np.uint8)
    patch = small_source(num_clusters=4, num_pcs=8).model.state_dict()
    torch.save({"num_pcs": 8, "state_dict": patch}, tmp_path / "pitts_WPCA8.pth.tar")
    nanne = small_source(num_clusters=4, num_pcs=0).model.state_dict()
    torch.save({"epoch": 1, "state_dict": nanne}, tmp_path / "checkpoint.pth.tar")

    backend = NetVLAD({"num_clusters": 4, "num_pcs": 0, "device": "cpu"})
    backend.load(tmp_path / "pitts_WPCA8.pth.tar")
    assert backend.preprocess(image).shape == (3, 480, 640)  # Patch-NetVLAD's imageresizeh x imageresizew
    backend.load(tmp_path / "checkpoint.pth.tar")
    full = backend.preprocess(image)
    assert full.shape == (3, 50, 70)  # Nanne's input_transform: ToTensor + Normalize, no Resize
    mean, std = torch.tensor([0.485, 0.456, 0.406]), torch.tensor([0.229, 0.224, 0.225])
    by_hand = (torch.from_numpy(image).permute(2, 0, 1) / 255.0 - mean[:, None, None]) / std[:, None, None]
    torch.testing.assert_close(full, by_hand, rtol=0, atol=1e-6)

    harness = NetVLAD({"num_clusters": 4, "num_pcs": 0, "device": "cpu", "preprocessing": "vpr-methods-evaluation"})
    harness.load(tmp_path / "pitts_WPCA8.pth.tar")
    assert harness.preprocess(image).shape == (3, 50, 70)  # that harness feeds full-size images
    fixed = NetVLAD({"num_clusters": 4, "num_pcs": 0, "device": "cpu", "image_size": [24, 32]})
    fixed.load(tmp_path / "checkpoint.pth.tar")
    assert fixed.preprocess(image).shape == (3, 24, 32)  # an explicit size wins


def test_bad_image_size_is_named() -> None:
    with pytest.raises(ValueError, match="image_size must be auto, null"):
        NetVLAD({"image_size": 480, "num_pcs": 0, "device": "cpu"})
