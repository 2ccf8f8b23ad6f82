"""MixVPR: official key lists, feature-mixer and projection maths, checkpoint round trips, preprocessing."""

from __future__ import annotations

import collections
import json
from pathlib import Path

import numpy as np
import pytest
import torch
from helpers import TESTS

from vpr_smr.descriptors import mixvpr
from vpr_smr.descriptors.base import CheckpointError

KEYS = TESTS / "data" / "keys"
SMALL = (64, 64)  # 4 x 4 trunk output: keeps CPU tests fast


def _randomise(model: torch.nn.Module, seed: int = 0) -> torch.nn.Module:
    generator = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for name, tensor in model.state_dict().items():
            if tensor.is_floating_point():
                noise = torch.rand(tensor.shape, generator=generator, dtype=tensor.dtype)
                if name.endswith("running_var"):
                    tensor.copy_(0.5 + noise)
                else:
                    tensor.add_(0.2 * (noise - 0.5))
    return model.eval()


def _image(height: int, width: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (height, width, 3), dtype=np.uint8)


def _lightning_checkpoint(state_dict: dict[str, torch.Tensor]) -> dict:
    """What pytorch-lightning 1.8 (MixVPR's requirements.txt) writes in a full checkpoint of main.py."""
    return {
        "epoch": 7,
        "global_step": 1234,
        "pytorch-lightning_version": "1.8.3",
        "state_dict": collections.OrderedDict(state_dict),
        "loops": {"fit_loop": {"state_dict": {}, "epoch_loop.state_dict": {"_batches_that_stepped": 1234}}},
        "callbacks": {"ModelCheckpoint{'monitor': 'R1'}": {"best_model_score": torch.tensor(0.9)}},
        "optimizer_states": [{"state": {}, "param_groups": [{"lr": 0.05, "momentum": 0.9, "params": [0]}]}],
        "lr_schedulers": [{"milestones": collections.Counter({5: 1, 10: 1}), "gamma": 0.3, "last_epoch": 7}],
        "hparams_name": "kwargs",
        "hyper_parameters": {"backbone_arch": "resnet50", "layers_to_crop": [4], "agg_arch": "MixVPR",
                             "agg_config": {"in_channels": 1024, "out_rows": 4}},
    }


@pytest.mark.parametrize(("dim", "channels", "rows"), [(4096, 1024, 4), (512, 256, 2), (128, 64, 2)])
def test_state_dict_matches_official_keys(dim: int, channels: int, rows: int):
    with torch.device("meta"):
        model = mixvpr.MixVPRNet((320, 320), channels, rows)
    ours = {key: list(value.shape) for key, value in model.state_dict().items()}
    official = json.loads((KEYS / f"mixvpr_resnet50_{dim}.json").read_text())
    assert list(ours) == list(official)
    assert ours == official
    assert not any("layer4" in key for key in ours)
    assert mixvpr.RELEASED[dim] == (channels, rows)


def test_trunk_size():
    assert mixvpr.trunk_size(320, 320) == (20, 20)
    trunk = mixvpr.ResNetTrunk().eval()
    with torch.no_grad():
        out = trunk(torch.zeros(1, 3, 37, 50))
    assert out.shape == (1, 1024, *mixvpr.trunk_size(37, 50))


def _naive_aggregator(agg: mixvpr.MixVPRAggregator, x: np.ndarray) -> np.ndarray:
    """Loops over channels and positions, written from the paper's equations."""
    p = {k: v.detach().numpy() for k, v in agg.state_dict().items()}
    batch, channels = x.shape[:2]
    rows = x.reshape(batch, channels, -1).copy()  # each channel's H*W values
    for i in range(len(agg.mix)):
        g, beta = p[f"mix.{i}.mix.0.weight"], p[f"mix.{i}.mix.0.bias"]
        w1, b1 = p[f"mix.{i}.mix.1.weight"], p[f"mix.{i}.mix.1.bias"]
        w2, b2 = p[f"mix.{i}.mix.3.weight"], p[f"mix.{i}.mix.3.bias"]
        for b in range(batch):
            for c in range(channels):
                r = rows[b, c]
                normed = (r - r.mean()) / np.sqrt(r.var() + 1e-5) * g + beta
                rows[b, c] = r + w2 @ np.maximum(w1 @ normed + b1, 0) + b2
    wc, bc = p["channel_proj.weight"], p["channel_proj.bias"]
    wr, br = p["row_proj.weight"], p["row_proj.bias"]
    out = np.zeros((batch, wc.shape[0], wr.shape[0]))
    for b in range(batch):
        projected = np.stack([wc @ rows[b, :, q] + bc for q in range(rows.shape[2])], axis=1)  # out_ch x HW
        for o in range(wc.shape[0]):
            out[b, o] = wr @ projected[o] + br
    flat = out.reshape(batch, -1)  # channel-major: index = o * out_rows + r
    return flat / np.linalg.norm(flat, axis=1, keepdims=True)


def test_mixer_and_projections_match_numpy():
    agg = mixvpr.MixVPRAggregator(
        in_channels=3, in_h=2, in_w=3, out_channels=5, mix_depth=2, mlp_ratio=2, out_rows=2
    )
    agg = _randomise(agg.double())
    x = torch.randn(2, 3, 2, 3, dtype=torch.float64)
    with torch.no_grad():
        ours = agg(x).numpy()
    assert ours.shape == (2, 10)
    np.testing.assert_allclose(ours, _naive_aggregator(agg, x.numpy()), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("form", ["plain", "lightning"])
def test_round_trip(tmp_path: Path, form: str):
    source = _randomise(mixvpr.MixVPRNet(SMALL, out_channels=8, out_rows=2))
    state_dict = source.state_dict()
    path = tmp_path / "resnet50_MixVPR_16_channels(8)_rows(2).ckpt"
    torch.save(state_dict if form == "plain" else _lightning_checkpoint(state_dict), path)

    backend = mixvpr.MixVPR({"image_size": list(SMALL), "device": "cpu"})
    backend.load(path)  # weights_only=True: the Lightning extras (Counter included) need no allow-listing
    assert backend.dim == 16  # out_channels and out_rows read from the file
    image = _image(50, 70)
    batch = backend.preprocess(image)[None]
    assert batch.shape == (1, 3, *SMALL)
    with torch.no_grad():
        expected = source(batch).numpy()
    np.testing.assert_array_equal(backend.forward(batch), expected)


def test_layer4_keys_and_wrong_size_are_reported(tmp_path: Path):
    state_dict = mixvpr.MixVPRNet(SMALL, out_channels=8, out_rows=2).state_dict()
    state_dict["backbone.model.layer4.0.conv1.weight"] = torch.zeros(512, 2048, 1, 1)
    path = tmp_path / "full_resnet.ckpt"
    torch.save({"state_dict": state_dict, "epoch": 1}, path)
    with pytest.raises(CheckpointError) as info:
        mixvpr.MixVPR({"device": "cpu"}).load(path)  # default 320 x 320: 400 positions, the file has 16
    message = str(info.value)
    for text in ("full_resnet.ckpt", "unexpected keys", "backbone.model.layer4.0.conv1.weight",
                 "wrong shapes", "aggregator.mix.0.mix.0.weight: file (16,), model (400,)",
                 "image_size [320, 320]", "resnet50_MixVPR_4096_channels(1024)_rows(4).ckpt"):
        assert text in message


def test_settings_and_foreign_files(tmp_path: Path):
    state_dict = mixvpr.MixVPRNet(SMALL, out_channels=8, out_rows=2).state_dict()
    path = tmp_path / "small.ckpt"
    torch.save(state_dict, path)
    backend = mixvpr.MixVPR({"image_size": list(SMALL), "out_rows": 4, "device": "cpu"})
    with pytest.raises(CheckpointError, match=r"out_rows = 2 but the setting is 4"):
        backend.load(path)
    other = tmp_path / "ResNet50_512_cosplace.pth"
    torch.save({"aggregation.3.weight": torch.zeros(512, 2048)}, other)
    with pytest.raises(CheckpointError, match=r"not a MixVPR checkpoint.*aggregator\.channel_proj\.weight"):
        backend.load(other)
    with pytest.raises(CheckpointError, match=r"needs a checkpoint: set `checkpoint` to resnet50_MixVPR_4096"):
        backend.load(None)


def test_preprocess_matches_official_validation_transform():
    from PIL import Image
    from torchvision import transforms as T

    image = _image(45, 61, seed=2)
    normalize = T.Normalize(mean=[0.485, 0.456, 0.406], std=[0.229, 0.224, 0.225])
    bilinear, bicubic = T.InterpolationMode.BILINEAR, T.InterpolationMode.BICUBIC
    valid = T.Compose([T.Resize((320, 320), interpolation=bilinear), T.ToTensor(), normalize])
    # Only preprocess is used: a backend instance is cheap enough at the default size.
    ours = mixvpr.MixVPR({"device": "cpu"}).preprocess(image)
    assert torch.equal(ours, valid(Image.fromarray(image)))  # GSVCitiesDataloader.valid_transform
    demo = T.Compose([T.Resize((320, 320), interpolation=bicubic), T.ToTensor(), normalize])
    ours = mixvpr.MixVPR({"device": "cpu", "interpolation": "bicubic"}).preprocess(image)
    assert torch.equal(ours, demo(Image.fromarray(image)))  # demo.py load_image


@pytest.mark.parametrize("shape", [(45, 61), (400, 500)])  # upsampling and (antialiased) downsampling
def test_preprocess_vpr_methods_evaluation(shape: tuple[int, int]):
    from PIL import Image
    from torchvision import transforms as T

    image = _image(*shape, seed=4)
    # VPR-methods-evaluation: test_dataset.py ToTensor + Normalize, then MixVPRModel.forward's
    # transforms.Resize([320, 320], antialias=True) on the normalised batch.
    normalised = T.Compose([T.ToTensor(), T.Normalize(mean=[0.485, 0.456, 0.406], std=[0.229, 0.224, 0.225])])
    expected = T.Resize([320, 320], antialias=True)(normalised(Image.fromarray(image))[None])[0]
    with torch.device("meta"):
        backend = mixvpr.MixVPR({"device": "cpu", "preprocessing": "vpr-methods-evaluation"})
    ours = backend.preprocess(image)
    assert ours.device.type == "cpu" and ours.shape == (3, 320, 320)
    assert torch.equal(ours, expected)
    with torch.device("meta"):
        official = mixvpr.MixVPR({"device": "cpu"})
    assert not torch.equal(official.preprocess(image), ours)  # PIL resize on uint8 first: other values
