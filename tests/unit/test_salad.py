"""SALAD backend: official key list, exact maths against naive re-implementations, checkpoint round trip."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import torch
import torch.nn.functional as F
from helpers import TESTS
from oracles import naive_aggregate, naive_sinkhorn, naive_vit_tokens

from vpr_smr.descriptors import backend_class
from vpr_smr.descriptors.base import CheckpointError
from vpr_smr.descriptors.dinov2 import DinoVisionTransformer, interpolate_pos_embed
from vpr_smr.descriptors.salad import SALAD, SALADAggregator, SALADNet, harness_size, log_sinkhorn_with_dustbin

KEYS_FILE = TESTS / "data" / "keys" / "salad_dino_salad.json"
TINY = {"embed_dim": 16, "depth": 2, "num_heads": 2, "num_clusters": 4, "cluster_dim": 3, "token_dim": 5}
TINY_IMAGE = [42, 56]  # 3 x 4 patches: more local features (12) than clusters (4), as Sinkhorn needs

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def full_backend() -> SALAD:
    torch.manual_seed(0)
    return SALAD({"device": "cpu"})


def tiny_backend() -> SALAD:
    return SALAD({**TINY, "image_size": TINY_IMAGE, "device": "cpu"})


def random_state_dict(model: torch.nn.Module, seed: int = 0) -> dict[str, torch.Tensor]:
    generator = torch.Generator().manual_seed(seed)
    return {k: torch.randn(v.shape, generator=generator) * (0.3 if v.ndim > 1 else 1.0)
            for k, v in model.state_dict().items()}


# ---------------------------------------------------------------- official key list and full-size model


def test_registry_resolves_salad() -> None:
    assert backend_class("salad").__name__ == "SALAD"


def test_state_dict_matches_official_keys(full_backend: SALAD) -> None:
    official = json.loads(KEYS_FILE.read_text())
    ours = {k: list(v.shape) for k, v in full_backend.model.state_dict().items()}
    assert ours == official
    assert "backbone.model.mask_token" in ours and len(ours) == 188


def test_full_model_on_322_input(full_backend: SALAD) -> None:
    image = np.random.default_rng(0).integers(0, 256, (240, 320, 3), dtype=np.uint8)
    batch = full_backend.preprocess(image)[None]
    assert tuple(batch.shape) == (1, 3, 322, 322)
    with torch.inference_mode():
        features, token = full_backend.model.backbone(batch)
        assert tuple(features.shape) == (1, 768, 23, 23) and tuple(token.shape) == (1, 768)
        descriptor = full_backend.model.aggregator(features, token).numpy()
    assert descriptor.shape == (1, 8448) and np.isfinite(descriptor).all()
    assert np.linalg.norm(descriptor[0]) == pytest.approx(1.0, abs=1e-5)


# ---------------------------------------------------------------- preprocessing


@pytest.mark.parametrize("shape", [(240, 320, 3), (500, 380, 3), (322, 322, 3)])
def test_preprocess_matches_official_eval_transform(shape: tuple[int, int, int]) -> None:
    # eval.py: T.Resize((322, 322), BILINEAR) on a PIL image, ToTensor, ImageNet Normalize.
    import torchvision.transforms as T
    from PIL import Image

    image = np.random.default_rng(1).integers(0, 256, shape, dtype=np.uint8)
    official = T.Compose([
        T.Resize((322, 322), interpolation=T.InterpolationMode.BILINEAR),
        T.ToTensor(),
        T.Normalize(mean=[0.485, 0.456, 0.406], std=[0.229, 0.224, 0.225]),
    ])(Image.fromarray(image))
    ours = SALAD({**TINY, "device": "cpu"}).preprocess(image)  # default image_size 322 x 322
    torch.testing.assert_close(ours, official, rtol=0, atol=1e-6)


def test_image_size_must_be_multiple_of_patch() -> None:
    with pytest.raises(ValueError, match="multiples of 14"):
        SALAD({**TINY, "image_size": [40, 56], "device": "cpu"})


@pytest.mark.parametrize(("height", "width", "expected"), [
    (100, 150, (98, 154)),  # 100 / 14 = 7.14 -> 7 -> 98; 150 / 14 = 10.71 -> 11 -> 154
    (21, 35, (28, 28)),  # 1.5 and 2.5: Python's round takes the even neighbour, 2 and 2
    (49, 322, (56, 322)),  # 3.5 -> 4; 23 exactly
])
def test_harness_rounding_by_hand(height: int, width: int, expected: tuple[int, int]) -> None:
    assert harness_size(height, width) == expected


def test_preprocess_vpr_methods_evaluation() -> None:
    # VPR-methods-evaluation: ToTensor + Normalize on the full image, then ResizingWrapper's
    # transforms.functional.resize(images, [98, 154], antialias=True) (bilinear) on the normalised batch.
    import torchvision.transforms as T
    import torchvision.transforms.functional as TF
    from PIL import Image

    image = np.random.default_rng(5).integers(0, 256, (100, 150, 3), dtype=np.uint8)
    normalised = T.Compose([T.ToTensor(), T.Normalize(mean=[0.485, 0.456, 0.406], std=[0.229, 0.224, 0.225])])
    expected = TF.resize(normalised(Image.fromarray(image))[None], [98, 154], antialias=True)[0]
    harness = SALAD({**TINY, "device": "cpu", "preprocessing": "vpr-methods-evaluation"})
    ours = harness.preprocess(image)
    assert ours.shape == (3, 98, 154)
    assert torch.equal(ours, expected)
    fixed = SALAD({**TINY, "device": "cpu", "preprocessing": "vpr-methods-evaluation", "image_size": [42, 56]})
    assert fixed.preprocess(image).shape == (3, 42, 56)  # an explicit size wins over both presets
    with pytest.raises(ValueError, match="too small"):
        harness.preprocess(np.zeros((6, 30, 3), dtype=np.uint8))  # 6 / 14 rounds to 0


# ---------------------------------------------------------------- position-embedding resampling


def naive_bicubic_axis(size_in: int, size_out: int, scale: float, a: float = -0.75) -> np.ndarray:
    """``(size_out, size_in)`` weights of PyTorch's bicubic: Keys a=-0.75, half-pixel centres, edge clamp."""
    def near(x: float) -> float:  # |x| <= 1
        return ((a + 2) * x - (a + 3)) * x * x + 1

    def far(x: float) -> float:  # 1 < |x| < 2
        return ((a * x - 5 * a) * x + 8 * a) * x - 4 * a

    weights = np.zeros((size_out, size_in))
    for out in range(size_out):
        source = scale * (out + 0.5) - 0.5
        base = math.floor(source)
        t = source - base
        for offset, w in zip((-1, 0, 1, 2), (far(t + 1), near(t), near(1 - t), far(2 - t)), strict=True):
            weights[out, min(max(base + offset, 0), size_in - 1)] += w
    return weights


@pytest.mark.parametrize("grid", [(23, 23), (16, 22)])
def test_pos_embed_matches_naive_bicubic(grid: tuple[int, int]) -> None:
    pos = torch.randn(1, 1 + 37 * 37, 6, generator=torch.Generator().manual_seed(2))
    ours = interpolate_pos_embed(pos, *grid).numpy()
    assert ours.shape == (1, 1 + grid[0] * grid[1], 6)
    # DINOv2 passes the factor (grid + 0.1) / 37, so the source step is 37 / (grid + 0.1), not 37 / grid.
    rows = naive_bicubic_axis(37, grid[0], 37 / (grid[0] + 0.1))
    cols = naive_bicubic_axis(37, grid[1], 37 / (grid[1] + 0.1))
    table = pos[0, 1:].numpy().astype(np.float64).reshape(37, 37, 6)
    expected = np.einsum("ir,jc,rcd->ijd", rows, cols, table).reshape(-1, 6)
    # float32 kernel vs float64 reference: ~1e-6 typical; the size-based resampling is off by ~0.8.
    np.testing.assert_allclose(ours[0, 1:], expected, atol=5e-5)
    np.testing.assert_array_equal(ours[0, 0], pos[0, 0].numpy())


def test_pos_embed_322_is_documented_interpolate_call() -> None:
    pos = torch.randn(1, 1 + 37 * 37, 8, generator=torch.Generator().manual_seed(3))
    ours = interpolate_pos_embed(pos, 322 // 14, 322 // 14)
    grid = pos[:, 1:].reshape(1, 37, 37, 8).permute(0, 3, 1, 2)
    direct = F.interpolate(grid, scale_factor=((23 + 0.1) / 37, (23 + 0.1) / 37), mode="bicubic",
                           antialias=False, align_corners=False)
    assert tuple(direct.shape[-2:]) == (23, 23)
    torch.testing.assert_close(ours[:, 1:], direct.permute(0, 2, 3, 1).reshape(1, 529, 8), rtol=0, atol=0)
    # Resampling to an output size instead of the factor gives a different embedding.
    by_size = F.interpolate(grid, size=(23, 23), mode="bicubic", antialias=False)
    assert (by_size.permute(0, 2, 3, 1).reshape(1, 529, 8) - ours[:, 1:]).abs().max() > 1e-2


def test_pos_embed_kept_for_square_518_input() -> None:
    vit = DinoVisionTransformer(embed_dim=8, depth=1, num_heads=2)
    assert vit.interpolate_pos_encoding(1 + 37 * 37, 518, 518) is vit.pos_embed
    assert vit.interpolate_pos_encoding(1 + 23 * 23, 322, 322).shape == (1, 530, 8)


# ---------------------------------------------------------------- Sinkhorn and aggregation


def test_sinkhorn_matches_naive_probability_space() -> None:
    rng = np.random.default_rng(4)
    scores = rng.normal(size=(2, 4, 9)) * 2
    ours = log_sinkhorn_with_dustbin(torch.tensor(scores), torch.tensor(0.7), 3).exp().numpy()
    assert ours.shape == (2, 5, 9)
    for b in range(2):
        expected = naive_sinkhorn(scores[b], 0.7)
        np.testing.assert_allclose(ours[b], expected, rtol=1e-10)
        np.testing.assert_allclose(expected.sum(axis=0), 1.0)  # last update matches the feature marginals


def test_sinkhorn_needs_more_features_than_clusters() -> None:
    with pytest.raises(ValueError, match="more local features"):
        log_sinkhorn_with_dustbin(torch.zeros(1, 4, 4), torch.tensor(1.0))


def test_aggregator_matches_naive() -> None:
    torch.manual_seed(5)
    aggregator = SALADAggregator(num_channels=8, num_clusters=4, cluster_dim=3, token_dim=5, hidden=6).eval()
    with torch.no_grad():
        aggregator.dust_bin.fill_(0.4)
    features = torch.randn(2, 8, 3, 3)
    token = torch.randn(2, 8)
    with torch.no_grad():
        ours = aggregator(features, token).numpy()
    params = {k: v.double().numpy() for k, v in aggregator.state_dict().items()}
    assert ours.shape == (2, 5 + 4 * 3)
    for b in range(2):
        local = features[b].flatten(1).T.double().numpy()  # (n, C), row-major patches
        expected = naive_aggregate(params, local, token[b].double().numpy())
        np.testing.assert_allclose(ours[b], expected, atol=1e-6)


# ---------------------------------------------------------------- whole network against a naive ViT


def test_tiny_network_matches_naive_implementation() -> None:
    model = SALADNet(**TINY).eval()
    sd = random_state_dict(model, seed=6)
    model.load_state_dict(sd)
    images = torch.randn(2, 3, *TINY_IMAGE, generator=torch.Generator().manual_seed(7))
    with torch.no_grad():
        ours = model(images).numpy()
    sd64 = {k: v.double() for k, v in sd.items()}
    params = {k.removeprefix("aggregator."): v.numpy() for k, v in sd64.items()
              if k.startswith("aggregator.")}
    for b in range(2):
        tokens = naive_vit_tokens(sd64, images[b].double(), TINY["depth"], TINY["num_heads"]).numpy()
        expected = naive_aggregate(params, tokens[1:], tokens[0])
        np.testing.assert_allclose(ours[b], expected, atol=2e-5)


# ---------------------------------------------------------------- checkpoint loading


@pytest.mark.parametrize("lightning", [False, True])
def test_round_trip_official_format(tmp_path: Path, lightning: bool) -> None:
    reference = SALADNet(**TINY).eval()
    sd = random_state_dict(reference, seed=8)
    reference.load_state_dict(sd)
    path = tmp_path / "dino_salad.ckpt"
    # The release is a plain state dict; Lightning training checkpoints wrap it under "state_dict".
    torch.save({"state_dict": sd, "epoch": 3, "global_step": 10} if lightning else sd, path)
    backend = tiny_backend()
    backend.load(path)
    images = [np.random.default_rng(9 + i).integers(0, 256, (60, 80, 3), dtype=np.uint8) for i in range(2)]
    batch = torch.stack([backend.preprocess(image) for image in images])
    ours = backend.forward(batch)
    with torch.no_grad():
        expected = reference(batch).numpy()
    assert ours.shape == (2, 5 + 4 * 3) and ours.dtype == np.float32
    np.testing.assert_allclose(ours, expected, rtol=0, atol=1e-6)


def test_mismatched_checkpoint_names_keys(tmp_path: Path) -> None:
    sd = random_state_dict(SALADNet(**TINY))
    del sd["backbone.model.mask_token"]
    sd["aggregator.extra"] = torch.zeros(2)
    sd["aggregator.score.3.bias"] = torch.zeros(7)
    path = tmp_path / "other.ckpt"
    torch.save(sd, path)
    with pytest.raises(CheckpointError) as error:
        tiny_backend().load(path)
    message = str(error.value)
    for expected in (str(path), "backbone.model.mask_token", "aggregator.extra", "aggregator.score.3.bias",
                     "dino_salad.ckpt"):
        assert expected in message


def test_missing_checkpoint_names_expected_file(tmp_path: Path) -> None:
    backend = tiny_backend()
    with pytest.raises(CheckpointError, match="dino_salad.ckpt"):
        backend.load(None)
    with pytest.raises(CheckpointError, match="not found"):
        backend.load(tmp_path / "dino_salad.ckpt")
