"""CosPlace / EigenPlaces: official key lists, GeM and aggregation maths, checkpoint round trips and
preprocessing."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from helpers import TESTS

from vpr_smr.descriptors import cosplace
from vpr_smr.descriptors.base import CheckpointError

KEYS = TESTS / "data" / "keys"
KEY_FILES = sorted(KEYS.glob("cosplace_*.json")) + sorted(KEYS.glob("eigenplaces_*.json"))


def _randomise(model: torch.nn.Module, seed: int = 0) -> torch.nn.Module:
    """Non-default values everywhere a file could differ: weights, BN statistics, GeM p."""
    generator = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for name, tensor in model.state_dict().items():
            if tensor.is_floating_point():
                noise = torch.rand(tensor.shape, generator=generator)
                if name.endswith("running_var") or name.endswith(".p"):
                    tensor.copy_(0.5 + noise)  # positive, p in [0.5, 1.5) + shift below
                else:
                    tensor.add_(0.1 * (noise - 0.5))
        model.aggregation[1].p.add_(2.0)
    return model.eval()


def _image(height: int, width: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (height, width, 3), dtype=np.uint8)


def test_key_files_present():
    names = {path.stem for path in KEY_FILES}
    assert {"cosplace_ResNet50_512", "cosplace_ResNet50_2048", "eigenplaces_ResNet50_512",
            "eigenplaces_ResNet50_2048", "cosplace_VGG16_512"} <= names


@pytest.mark.parametrize("path", KEY_FILES, ids=lambda path: path.stem)
def test_state_dict_matches_official_keys(path: Path):
    _, backbone, dim = path.stem.split("_")
    with torch.device("meta"):  # shapes only: no memory, no initialisation
        model = cosplace.GeoLocalizationNet(backbone, int(dim))
    ours = {key: list(value.shape) for key, value in model.state_dict().items()}
    official = json.loads(path.read_text())
    assert list(ours) == list(official)
    assert ours == official


def test_released_backbones_and_dims():
    assert cosplace.CosPlace.released["ResNet50"][-2:] == [1024, 2048]
    assert max(cosplace.CosPlace.released["VGG16"]) == 512
    assert "ResNet152" not in cosplace.EigenPlaces.released
    assert cosplace.EigenPlaces.released["VGG16"] == [512]


def test_gem_matches_numpy():
    x = torch.randn(2, 3, 4, 5, dtype=torch.float64)  # negative values exercise the clamp
    gem = cosplace.GeM().double()
    with torch.no_grad():
        gem.p.fill_(2.5)
    with torch.no_grad():
        ours = gem(x).numpy()
    naive = np.zeros((2, 3, 1, 1))
    for b in range(2):
        for c in range(3):
            values = np.maximum(x[b, c].numpy(), 1e-6) ** 2.5
            naive[b, c, 0, 0] = values.mean() ** (1 / 2.5)
    assert gem.p.shape == (1,) and gem.eps == 1e-6
    np.testing.assert_allclose(ours, naive, rtol=1e-12)


def test_aggregation_matches_numpy():
    net = _randomise(cosplace.GeoLocalizationNet("ResNet18", 6)).double()
    features = torch.randn(2, 512, 3, 4, dtype=torch.float64)
    with torch.no_grad():
        ours = net.aggregation(features).numpy()
    p = float(net.aggregation[1].p.detach())
    weight = net.aggregation[3].weight.detach().numpy()
    bias = net.aggregation[3].bias.detach().numpy()
    expected = []
    for f in features.numpy():
        f = f / np.maximum(np.linalg.norm(f, axis=0, keepdims=True), 1e-12)  # L2 per location
        pooled = (np.maximum(f, 1e-6) ** p).mean(axis=(1, 2)) ** (1 / p)
        out = weight @ pooled + bias
        expected.append(out / np.linalg.norm(out))
    np.testing.assert_allclose(ours, np.array(expected), rtol=1e-10, atol=1e-12)


def test_vgg16_trunk_is_cut_before_last_relu():
    trunk = cosplace.build_backbone("VGG16")
    assert len(trunk) == 29 and isinstance(trunk[-1], torch.nn.Conv2d)


@pytest.mark.parametrize(
    ("cls", "backbone", "dim", "wrap"),
    [
        (cosplace.CosPlace, "ResNet18", 256, "plain"),
        (cosplace.CosPlace, "ResNet18", 512, "module"),
        (cosplace.EigenPlaces, "VGG16", 128, "state_dict"),
    ],
)
def test_round_trip(tmp_path: Path, cls, backbone: str, dim: int, wrap: str):
    source = _randomise(cosplace.GeoLocalizationNet(backbone, dim))
    state_dict = source.state_dict()
    if wrap == "module":  # a DataParallel save
        state_dict = {f"module.{key}": value for key, value in state_dict.items()}
    saved = {"state_dict": state_dict, "epoch": 3} if wrap == "state_dict" else state_dict
    path = tmp_path / f"{backbone}_{dim}_{cls.name}.pth"
    torch.save(saved, path)

    backend = cls({"backbone": backbone, "device": "cpu"})
    backend.load(path)
    assert backend.dim == dim  # read from aggregation.3.weight
    image = _image(40, 56)
    batch = backend.preprocess(image)[None]
    with torch.no_grad():
        expected = source(batch).numpy()
    np.testing.assert_array_equal(backend.forward(batch), expected)
    assert np.isclose(np.linalg.norm(backend.describe(image)), 1.0)


def test_wrong_backbone_is_named(tmp_path: Path):
    path = tmp_path / "ResNet18_512_cosplace.pth"
    torch.save(cosplace.GeoLocalizationNet("ResNet18", 512).state_dict(), path)
    pattern = r"ResNet18 backbone.*backbone: VGG16.*VGG16_<dim>_cosplace\.pth"
    with pytest.raises(CheckpointError, match=pattern):
        cosplace.CosPlace({"backbone": "VGG16", "device": "cpu"}).load(path)


def test_missing_and_unexpected_keys_are_listed(tmp_path: Path):
    state_dict = cosplace.GeoLocalizationNet("ResNet18", 64).state_dict()
    del state_dict["aggregation.1.p"]
    state_dict["aggregation.9.weight"] = torch.zeros(3)
    state_dict["backbone.0.weight"] = torch.zeros(64, 3, 5, 5)
    path = tmp_path / "edited.pth"
    torch.save(state_dict, path)
    with pytest.raises(CheckpointError) as info:
        cosplace.EigenPlaces({"backbone": "ResNet18", "device": "cpu"}).load(path)
    message = str(info.value)
    for text in ("edited.pth", "missing keys", "aggregation.1.p", "unexpected keys", "aggregation.9.weight",
                 "wrong shapes", "backbone.0.weight", "ResNet18_<dim>_eigenplaces.pth", "256, 512"):
        assert text in message


def test_dimension_setting_is_checked(tmp_path: Path):
    path = tmp_path / "ResNet18_32_cosplace.pth"
    torch.save(cosplace.GeoLocalizationNet("ResNet18", 32).state_dict(), path)
    with pytest.raises(CheckpointError, match=r"32-d descriptors but `fc_output_dim` is 512"):
        cosplace.CosPlace({"backbone": "ResNet18", "fc_output_dim": 512, "device": "cpu"}).load(path)


def test_foreign_and_absent_files(tmp_path: Path):
    path = tmp_path / "other.pth"
    torch.save({"aggregator.row_proj.weight": torch.zeros(4, 400)}, path)
    backend = cosplace.CosPlace({"backbone": "VGG16", "device": "cpu"})
    pattern = r"other\.pth is not a cosplace checkpoint.*VGG16_<dim>_cosplace"
    with pytest.raises(CheckpointError, match=pattern):
        backend.load(path)
    with pytest.raises(CheckpointError, match=r"needs a checkpoint: set `checkpoint` to VGG16_<dim>_cosplace"):
        backend.load(None)
    backend = cosplace.CosPlace({"backbone": "VGG16", "device": "cpu", "fc_output_dim": 512})
    with pytest.raises(CheckpointError, match=r"not found.*\n.*expected VGG16_512_cosplace\.pth"):
        backend.load(tmp_path / "absent.pth")


def test_unknown_backbone():
    with pytest.raises(ValueError, match="ResNet152"):
        cosplace.EigenPlaces({"backbone": "ResNet152"})


def test_preprocess_matches_official_transforms():
    from PIL import Image
    from torchvision import transforms

    image = _image(37, 50, seed=1)
    normalize = transforms.Normalize(mean=[0.485, 0.456, 0.406], std=[0.229, 0.224, 0.225])
    full = transforms.Compose([transforms.ToTensor(), normalize])(Image.fromarray(image))
    ours = cosplace.CosPlace({"backbone": "VGG16", "device": "cpu"}).preprocess(image)
    assert torch.equal(ours, full)  # full size, as the official eval.py

    resized = transforms.Compose([transforms.Resize(24, antialias=True), transforms.ToTensor(), normalize])
    expected = resized(Image.fromarray(image))  # test_dataset.py with --resize_test_imgs --image_size 24
    ours = cosplace.CosPlace({"backbone": "VGG16", "device": "cpu", "resize": 24}).preprocess(image)
    assert ours.shape == expected.shape == (3, 24, 32)
    assert torch.equal(ours, expected)
    assert cosplace.resized_size(50, 37, 24) == (32, 24)


def test_vpr_methods_evaluation_preset_changes_nothing():
    # That harness's test_dataset.py feeds ToTensor + Normalize at full size, as CosPlace's own evaluation.
    image = _image(37, 50, seed=2)
    with torch.device("meta"):
        official = cosplace.CosPlace({"backbone": "VGG16", "device": "cpu"})
        harness = cosplace.EigenPlaces({"backbone": "VGG16", "device": "cpu",
                                        "preprocessing": "vpr-methods-evaluation"})
    assert torch.equal(official.preprocess(image), harness.preprocess(image))
