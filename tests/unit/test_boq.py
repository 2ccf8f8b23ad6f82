"""BoQ backend: official key lists, exact maths against naive re-implementations, eval mode, checkpoint round trips
and wrong files, both preprocessing presets."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TypeVar

import numpy as np
import pytest
import torch
from helpers import TESTS

from vpr_smr.descriptors import backend_class, boq
from vpr_smr.descriptors.base import CheckpointError
from vpr_smr.descriptors.boq import BoQ, BoQAggregator, BoQBlock, BoQNet, EncoderLayer
from vpr_smr.descriptors.extract import check_checkpoint
from vpr_smr.pipeline.cli import main as cli_main

KEYS = TESTS / "data" / "keys"
# Small models: the aggregator with 64 channels (1 head), 4 queries, 2 rows; for DINOv2 a 64-wide, 2-block ViT.
TINY_AGG = {"proj_channels": 64, "num_queries": 4, "num_layers": 2, "row_dim": 2}
TINY_VIT = {"embed_dim": 64, "depth": 2}
SMALL = [64, 64]  # ResNet input: 4 x 4 feature map
SMALL_VIT = [42, 56]  # DINOv2 input: 3 x 4 patches
MEAN, STD = [0.485, 0.456, 0.406], [0.229, 0.224, 0.225]
M = TypeVar("M", bound=torch.nn.Module)


def randomise(model: M, seed: int = 0) -> M:
    """Random weights of a sane scale (norm weights near 1, positive running variances), eval mode."""
    generator = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for name, tensor in model.state_dict().items():
            if not tensor.is_floating_point():
                continue
            noise = torch.randn(tensor.shape, generator=generator, dtype=tensor.dtype)
            if name.endswith("running_var"):
                tensor.copy_(0.5 + noise.abs())
            elif tensor.ndim == 1 and name.endswith("weight"):
                tensor.copy_(1.0 + 0.1 * noise)
            elif tensor.ndim == 1:
                tensor.copy_(0.1 * noise)
            else:
                fan_in = tensor[0].numel() if tensor.ndim > 1 else 1
                tensor.copy_(noise / math.sqrt(fan_in) if fan_in > 1 else 0.5 * noise)
    return model.eval()


def image(height: int, width: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (height, width, 3), dtype=np.uint8)


def tiny_resnet(seed: int = 0) -> BoQNet:
    return randomise(BoQNet("resnet50", **TINY_AGG), seed)


def tiny_dinov2(seed: int = 0) -> BoQNet:
    return randomise(BoQNet("dinov2", **TINY_AGG, **TINY_VIT), seed)


# ---------------------------------------------------------------- official key lists


def test_registry_resolves_boq() -> None:
    assert backend_class("boq") is BoQ


@pytest.mark.parametrize(("backbone", "dim", "count"), [("resnet50", 16384, 314), ("dinov2", 12288, 231)])
def test_state_dict_matches_official_keys(backbone: str, dim: int, count: int) -> None:
    with torch.device("meta"):
        model = BoQNet(backbone)
    ours = {key: list(value.shape) for key, value in model.state_dict().items()}
    official = json.loads((KEYS / f"boq_{backbone}_{dim}.json").read_text())
    assert ours == official
    assert len(ours) == count and model.dim == dim == boq.RELEASED[backbone][1]
    if backbone == "resnet50":
        assert list(ours) == list(official)  # the same order too
        assert {key.split(".")[2] for key in ours if key.startswith("backbone.")} == {"0", "1", "4", "5", "6"}
    else:  # stored and loaded, though the forward pass uses neither
        assert {"backbone.dino.norm.weight", "backbone.dino.norm.bias", "backbone.dino.mask_token"} <= set(ours)
    shapes = {key: torch.empty(shape, device="meta") for key, shape in official.items()}
    assert boq.detect_backbone(shapes) == backbone
    assert boq.file_sizes(shapes) == model.sizes


# ---------------------------------------------------------------- exact maths on small inputs


def naive_layer_norm(x: np.ndarray, weight: np.ndarray, bias: np.ndarray, eps: float = 1e-5) -> np.ndarray:
    mean = x.mean(axis=-1, keepdims=True)
    var = ((x - mean) ** 2).mean(axis=-1, keepdims=True)
    return (x - mean) / np.sqrt(var + eps) * weight + bias


def naive_attention(query: np.ndarray, keys: np.ndarray, p: dict[str, np.ndarray], prefix: str,
                    heads: int) -> np.ndarray:
    """Multi-head attention written out: per head softmax(Q K^T / sqrt(d)) V, heads concatenated, projected."""
    dim = query.shape[-1]
    w, b = p[f"{prefix}.in_proj_weight"], p[f"{prefix}.in_proj_bias"]
    q = query @ w[:dim].T + b[:dim]
    k = keys @ w[dim:2 * dim].T + b[dim:2 * dim]
    v = keys @ w[2 * dim:].T + b[2 * dim:]
    d = dim // heads
    out = np.zeros((query.shape[0], dim))
    for h in range(heads):
        cols = slice(h * d, (h + 1) * d)
        for i in range(query.shape[0]):
            scores = np.array([q[i, cols] @ k[j, cols] for j in range(keys.shape[0])]) / math.sqrt(d)
            weights = np.exp(scores - scores.max())
            weights /= weights.sum()
            out[i, cols] = sum(weights[j] * v[j, cols] for j in range(keys.shape[0]))
    return out @ p[f"{prefix}.out_proj.weight"].T + p[f"{prefix}.out_proj.bias"]


def naive_block(x: np.ndarray, p: dict[str, np.ndarray], heads: int) -> tuple[np.ndarray, np.ndarray]:
    """One BoQ block for one image: tokens ``(N, D)`` -> (refined tokens, output ``(Q, D)``)."""
    ln = lambda t, name: naive_layer_norm(t, p[f"{name}.weight"], p[f"{name}.bias"])  # noqa: E731
    # encoder: nn.TransformerEncoderLayer, post-norm, ReLU feed-forward
    x = ln(x + naive_attention(x, x, p, "encoder.self_attn", heads), "encoder.norm1")
    hidden = np.maximum(x @ p["encoder.linear1.weight"].T + p["encoder.linear1.bias"], 0)
    x = ln(x + hidden @ p["encoder.linear2.weight"].T + p["encoder.linear2.bias"], "encoder.norm2")
    q = p["queries"][0]
    q = ln(q + naive_attention(q, q, p, "self_attn", heads), "norm_q")
    out = ln(naive_attention(q, x, p, "cross_attn", heads), "norm_out")  # no residual
    return x, out


def naive_conv3x3(x: np.ndarray, weight: np.ndarray, bias: np.ndarray) -> np.ndarray:
    channels, height, width = x.shape
    padded = np.zeros((channels, height + 2, width + 2))
    padded[:, 1:-1, 1:-1] = x
    out = np.zeros((weight.shape[0], height, width))
    for o in range(weight.shape[0]):
        for i in range(height):
            for j in range(width):
                out[o, i, j] = (padded[:, i:i + 3, j:j + 3] * weight[o]).sum() + bias[o]
    return out


def naive_aggregator(agg: BoQAggregator, features: np.ndarray, heads: int) -> np.ndarray:
    p = {k: v.detach().numpy() for k, v in agg.state_dict().items()}
    results = []
    for fmap in features:
        projected = naive_conv3x3(fmap, p["proj_c.weight"], p["proj_c.bias"])
        tokens = projected.reshape(projected.shape[0], -1).T  # positions row-major
        x = naive_layer_norm(tokens, p["norm_input.weight"], p["norm_input.bias"])
        outs = []
        for i in range(len(agg.boqs)):
            block = {k.split(".", 2)[2]: v for k, v in p.items() if k.startswith(f"boqs.{i}.")}
            x, out = naive_block(x, block, heads)
            outs.append(out)
        stacked = np.concatenate(outs)  # (L*Q, P)
        rows = p["fc.weight"] @ stacked + p["fc.bias"][:, None]  # (row_dim, P)
        flat = rows.T.reshape(-1)  # channel-major: index c * row_dim + r
        results.append(flat / np.linalg.norm(flat))
    return np.stack(results)


def test_cross_attention_matches_softmax_formula() -> None:
    block = randomise(BoQBlock(dim=12, num_queries=5, num_heads=3).double())
    x = torch.randn(2, 7, 12, dtype=torch.float64, generator=torch.Generator().manual_seed(1))
    q = torch.randn(2, 5, 12, dtype=torch.float64, generator=torch.Generator().manual_seed(2))
    with torch.no_grad():
        ours = block.cross_attn(q, x, x, need_weights=False)[0].numpy()
    p = {k: v.numpy() for k, v in block.state_dict().items()}
    for b in range(2):
        expected = naive_attention(q[b].numpy(), x[b].numpy(), p, "cross_attn", heads=3)
        np.testing.assert_allclose(ours[b], expected, rtol=1e-12, atol=1e-12)


def test_boq_block_matches_naive() -> None:
    block = randomise(BoQBlock(dim=12, num_queries=5, num_heads=3).double(), seed=3)
    x = torch.randn(2, 7, 12, dtype=torch.float64, generator=torch.Generator().manual_seed(4))
    with torch.no_grad():
        refined, out = block(x)
    assert refined.shape == (2, 7, 12) and out.shape == (2, 5, 12)
    p = {k: v.numpy() for k, v in block.state_dict().items()}
    for b in range(2):
        naive_x, naive_out = naive_block(x[b].numpy(), p, heads=3)
        np.testing.assert_allclose(refined[b].numpy(), naive_x, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(out[b].numpy(), naive_out, rtol=1e-10, atol=1e-12)


def test_encoder_layer_is_torch_transformer_encoder_layer() -> None:
    """The official encoder is nn.TransformerEncoderLayer(d, heads, 4d, dropout=0, batch_first=True)."""
    ours = randomise(EncoderLayer(16, 2, 64).double(), seed=5)
    reference = torch.nn.TransformerEncoderLayer(16, 2, dim_feedforward=64, dropout=0.0, batch_first=True)
    reference.double().load_state_dict(ours.state_dict(), strict=True)
    x = torch.randn(3, 9, 16, dtype=torch.float64, generator=torch.Generator().manual_seed(6))
    with torch.no_grad():
        torch.testing.assert_close(ours(x), reference.eval()(x), rtol=1e-12, atol=1e-12)


def test_aggregator_matches_naive() -> None:
    agg = randomise(BoQAggregator(3, 8, num_queries=4, num_layers=2, row_dim=3, num_heads=2).double(), seed=7)
    features = torch.randn(2, 3, 3, 4, dtype=torch.float64, generator=torch.Generator().manual_seed(8))
    with torch.no_grad():
        ours = agg(features).numpy()
    assert ours.shape == (2, 8 * 3)
    np.testing.assert_allclose(ours, naive_aggregator(agg, features.numpy(), heads=2), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(ours, axis=1), 1.0, rtol=1e-12)


@pytest.mark.parametrize(("channels", "heads"), [(512, 8), (384, 6), (64, 1)])
def test_heads_are_channels_over_64(channels: int, heads: int) -> None:
    with torch.device("meta"):
        agg = BoQAggregator(16, channels)
    attention = [m for m in agg.modules() if isinstance(m, torch.nn.MultiheadAttention)]
    assert len(attention) == 6 and {m.num_heads for m in attention} == {heads}


def test_learned_queries_do_not_depend_on_the_image() -> None:
    block = randomise(BoQBlock(dim=8, num_queries=3, num_heads=2))
    with torch.no_grad():
        q = block.learned_queries()
        expected = block.norm_q(block.queries + block.self_attn(block.queries, block.queries, block.queries)[0])
    torch.testing.assert_close(q, expected)


# ---------------------------------------------------------------- the full models


@pytest.mark.parametrize(("backbone", "dim", "size"), [("resnet50", 16384, (384, 384)), ("dinov2", 12288, (322, 322))])
def test_released_sizes_dims_and_unit_norm(backbone: str, dim: int, size: tuple[int, int]) -> None:
    torch.manual_seed(0)
    backend = BoQ({"backbone": backbone, "device": "cpu"})
    assert backend.dim == dim and backend.input_size() == size and not backend.model.training
    batch = backend.preprocess(image(240, 320))[None]
    assert tuple(batch.shape) == (1, 3, *size)
    with torch.inference_mode():
        features = backend.model.backbone(batch)
    channels = 1024 if backbone == "resnet50" else 768
    grid = (24, 24) if backbone == "resnet50" else (23, 23)
    assert tuple(features.shape) == (1, channels, *grid)
    descriptor = backend.forward(batch)
    assert descriptor.shape == (1, dim) and descriptor.dtype == np.float32 and np.isfinite(descriptor).all()
    assert np.linalg.norm(descriptor[0]) == pytest.approx(1.0, abs=1e-5)


def test_eval_mode_batch_composition_does_not_change_a_descriptor() -> None:
    """BatchNorm uses its running statistics: an image's descriptor does not depend on its batch."""
    model = tiny_resnet(seed=1)
    a, b, c = (torch.randn(1, 3, *SMALL, generator=torch.Generator().manual_seed(s)) for s in (1, 2, 3))
    with torch.no_grad():
        with_b = model(torch.cat([a, b]))
        with_c = model(torch.cat([a, c, c]))
        alone = model(a)
        model.train()  # what the official loader hands back: batch statistics
        trained = model(torch.cat([a, b]))[0]
        model.eval()
    torch.testing.assert_close(with_b[0], with_c[0], rtol=0, atol=1e-6)
    torch.testing.assert_close(with_b[0], alone[0], rtol=0, atol=1e-6)
    assert (trained - with_b[0]).abs().max() > 1e-3  # training mode would have changed it


def test_dinov2_ignores_final_norm_and_mask_token() -> None:
    model = tiny_dinov2(seed=2)
    x = torch.randn(2, 3, *SMALL_VIT, generator=torch.Generator().manual_seed(3))
    with torch.no_grad():
        before = model(x)
        vit = model.backbone.dino
        vit.norm.weight.mul_(3.0).add_(1.0)
        vit.norm.bias.add_(2.0)
        vit.mask_token.add_(5.0)
        after = model(x)
        assert torch.equal(before, after)
        vit.blocks[-1].mlp.fc2.bias.add_(0.5)  # a weight that is used does change it
        assert not torch.allclose(before, model(x))


def test_dinov2_backbone_gives_the_blocks_patch_tokens_as_a_map() -> None:
    model = tiny_dinov2(seed=4)
    x = torch.randn(1, 3, *SMALL_VIT, generator=torch.Generator().manual_seed(5))
    with torch.no_grad():
        fmap = model.backbone(x)
        vit = model.backbone.dino
        tokens = vit.prepare_tokens(x)
        for block in vit.blocks:
            tokens = block(tokens)
    assert fmap.shape == (1, 64, 3, 4)
    for row in range(3):
        for col in range(4):
            torch.testing.assert_close(fmap[0, :, row, col], tokens[0, 1 + row * 4 + col], rtol=0, atol=0)


# ---------------------------------------------------------------- checkpoints


@pytest.mark.parametrize("backbone", ["resnet50", "dinov2"])
def test_round_trip_reads_backbone_and_sizes_from_the_file(tmp_path: Path, backbone: str) -> None:
    source = tiny_resnet(seed=6) if backbone == "resnet50" else tiny_dinov2(seed=6)
    path = tmp_path / f"{backbone}_128.pth"
    torch.save(source.state_dict(), path)  # a plain state dict, as the releases
    size = SMALL if backbone == "resnet50" else SMALL_VIT
    backend = BoQ({"image_size": size, "device": "cpu"})  # backbone and output_dim: null
    backend.load(path)
    assert backend.backbone_kind == backbone and backend.dim == 64 * 2 and not backend.model.training
    assert backend.model.sizes == source.sizes
    images = [image(50, 70, seed) for seed in (1, 2)]
    batch = torch.stack([backend.preprocess(im) for im in images])
    assert tuple(batch.shape) == (2, 3, *size)
    with torch.no_grad():
        expected = source(batch).numpy()
    ours = backend.forward(batch)
    np.testing.assert_allclose(ours, expected, rtol=0, atol=1e-6)
    # The settings, when given, must agree with the file; here they do.
    explicit = BoQ({"image_size": size, "device": "cpu", "backbone": backbone, "output_dim": 128})
    explicit.load(path)
    np.testing.assert_allclose(explicit.forward(batch), expected, rtol=0, atol=1e-6)
    assert check_checkpoint({"backend": "boq", "checkpoint": str(path), "image_size": size}) is not None


def test_auto_size_follows_the_loaded_variant(tmp_path: Path) -> None:
    path = tmp_path / "tiny_dinov2.pth"
    torch.save(tiny_dinov2().state_dict(), path)
    backend = BoQ({"device": "cpu"})
    assert backend.input_size() == (384, 384)  # before loading: the default ResNet-50
    backend.load(path)
    assert backend.input_size() == (322, 322)
    assert backend.preprocess(image(100, 120)).shape == (3, 322, 322)


def test_resnet_wrong_files(tmp_path: Path) -> None:
    state_dict = tiny_resnet().state_dict()
    # BoQ's training code between 661e576 and 87ff48c kept the ResNet in frozen_layers / unfrozen_layers.
    old = {k.replace("backbone.net.0.", "backbone.frozen_layers.0.0.").replace("backbone.net.6.",
                                                                               "backbone.unfrozen_layers.0."): v
           for k, v in state_dict.items()}
    old["aggregator.proj_c.weight"] = torch.zeros(64, 2048, 3, 3)  # a map after layer4
    path = tmp_path / "old_layout.pth"
    torch.save(old, path)
    with pytest.raises(CheckpointError) as info:
        BoQ({"image_size": SMALL, "device": "cpu"}).load(path)
    message = str(info.value)
    for text in (str(path), "missing keys", "backbone.net.0.weight", "unexpected keys",
                 "backbone.frozen_layers.0.0.weight", "wrong shapes",
                 "aggregator.proj_c.weight: file (64, 2048, 3, 3), model (64, 1024, 3, 3)",
                 "from 661e576 to 87ff48c", "resnet50_16384.pth"):
        assert text in message
    # The right file, but a setting that contradicts it.
    good = tmp_path / "resnet50_128.pth"
    torch.save(state_dict, good)
    with pytest.raises(CheckpointError, match=r"resnet50 backbone \(backbone\.net\.\* keys\) but the setting is "
                                              r"`backbone: dinov2`; set `backbone: resnet50` or null"):
        BoQ({"backbone": "dinov2", "device": "cpu"}).load(good)
    with pytest.raises(CheckpointError, match=r"gives 128-d descriptors \(64 channels x 2 rows\) but the setting "
                                              r"is `output_dim: 16384`.*resnet50_16384\.pth"):
        BoQ({"image_size": SMALL, "output_dim": 16384, "device": "cpu"}).load(good)


def test_dinov2_wrong_file(tmp_path: Path) -> None:
    state_dict = tiny_dinov2().state_dict()
    # A model whose final norm was replaced by nn.Identity (BoQ's 706bdfb) saves no norm keys.
    del state_dict["backbone.dino.norm.weight"], state_dict["backbone.dino.norm.bias"]
    state_dict["aggregator.extra.weight"] = torch.zeros(3)
    state_dict["aggregator.norm_input.bias"] = torch.zeros(65)
    path = tmp_path / "no_norm.pth"
    torch.save(state_dict, path)
    with pytest.raises(CheckpointError) as info:
        BoQ({"image_size": SMALL_VIT, "device": "cpu", "backbone": "dinov2"}).load(path)
    message = str(info.value)
    for text in (str(path), "2 missing keys", "backbone.dino.norm.weight", "backbone.dino.norm.bias",
                 "1 unexpected keys", "aggregator.extra.weight", "wrong shapes",
                 "aggregator.norm_input.bias: file (65,), model (64,)", "dinov2_12288.pth", "backbone.dino.*",
                 "no backbone.dino.norm.* keys", "replaced by nn.Identity"):
        assert text in message
    assert "resnet50_16384.pth" not in message  # the setting names the variant: only its file is expected


def test_foreign_file_and_missing_checkpoint(tmp_path: Path) -> None:
    path = tmp_path / "mixvpr.ckpt"
    torch.save({"backbone.model.conv1.weight": torch.zeros(64, 3, 7, 7),
                "aggregator.channel_proj.weight": torch.zeros(1024, 1024)}, path)
    with pytest.raises(CheckpointError) as info:
        BoQ({"device": "cpu"}).load(path)
    message = str(info.value)
    for text in ("missing keys", "backbone.net.0.weight", "unexpected keys", "aggregator.channel_proj.weight",
                 "neither backbone.net.* (ResNet-50) nor backbone.dino.* (DINOv2)",
                 "resnet50_16384.pth or dinov2_12288.pth"):
        assert text in message
    with pytest.raises(CheckpointError, match=r"needs a checkpoint: set `checkpoint` to resnet50_16384\.pth or "
                                              r"dinov2_12288\.pth"):
        BoQ({"device": "cpu"}).load(None)
    with pytest.raises(CheckpointError, match="not found"):
        BoQ({"device": "cpu"}).load(tmp_path / "dinov2_12288.pth")


def test_checkpoint_check_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "dinov2_128.pth"
    torch.save(tiny_dinov2().state_dict(), path)
    assert cli_main(["checkpoint", "check", "boq", str(path), "--option", "device=cpu"]) == 0
    out = capsys.readouterr().out
    assert "OK:" in out and "backend 'boq' (strict); descriptor size 128" in out
    assert cli_main(["checkpoint", "check", "boq", str(path), "--option", "device=cpu",
                     "--option", "backbone=resnet50"]) == 1
    err = capsys.readouterr().err
    assert "NOT OK:" in err and "set `backbone: dinov2` or null" in err
    with pytest.raises(CheckpointError, match="set `backbone: dinov2`"):  # the preflight's check, the same
        check_checkpoint({"backend": "boq", "checkpoint": str(path), "backbone": "resnet50"}, method="boq")


# ---------------------------------------------------------------- settings and preprocessing


def test_settings_are_checked() -> None:
    with pytest.raises(ValueError, match="backbone must be one of resnet50, dinov2 or null"):
        BoQ({"backbone": "vgg16", "device": "cpu"})
    with pytest.raises(ValueError, match="image_size must be auto or"):
        BoQ({"image_size": 320, "device": "cpu"})
    with pytest.raises(ValueError, match="output_dim must be a positive integer or null"):
        BoQ({"output_dim": "16384", "device": "cpu"})
    with pytest.raises(ValueError, match=r"image_size \[320, 320\] must be multiples of 14"):
        with torch.device("meta"):
            BoQ({"backbone": "dinov2", "image_size": [320, 320], "device": "cpu"})


def meta_backend(backbone: str, **conf: object) -> BoQ:
    with torch.device("meta"):  # preprocessing needs no weights
        return BoQ({"backbone": backbone, "device": "cpu", **conf})


@pytest.mark.parametrize(("backbone", "size"), [("resnet50", (384, 384)), ("dinov2", (322, 322))])
@pytest.mark.parametrize("shape", [(240, 320), (500, 380), (384, 384)])
def test_preprocess_matches_readme_transform(backbone: str, size: tuple[int, int], shape: tuple[int, int]) -> None:
    import torchvision.transforms as T
    from PIL import Image

    im = image(*shape, seed=7)
    # README ("when using our models, use the following transform"): ToTensor, bicubic antialiased Resize, Normalize.
    official = T.Compose([T.ToTensor(), T.Resize(size, interpolation=T.InterpolationMode.BICUBIC, antialias=True),
                          T.Normalize(mean=MEAN, std=STD)])(Image.fromarray(im))
    ours = meta_backend(backbone).preprocess(im)
    assert ours.device.type == "cpu" and ours.shape == (3, *size)
    assert torch.equal(ours, official)


@pytest.mark.parametrize(("backbone", "size"), [("resnet50", [384, 384]), ("dinov2", [322, 322])])
def test_preprocess_vpr_methods_evaluation(backbone: str, size: list[int]) -> None:
    import torchvision.transforms as T
    from PIL import Image

    im = image(300, 400, seed=8)
    # VPR-methods-evaluation: parser.py sets --image_size for boq; test_dataset.py ToTensor, Normalize, then
    # transforms.Resize(size=image_size, antialias=True) (bilinear) on the normalised tensor.
    expected = T.Compose([T.ToTensor(), T.Normalize(mean=MEAN, std=STD), T.Resize(size=size, antialias=True)])(
        Image.fromarray(im))
    ours = meta_backend(backbone, preprocessing="vpr-methods-evaluation").preprocess(im)
    assert torch.equal(ours, expected)
    assert not torch.equal(meta_backend(backbone).preprocess(im), ours)  # the presets differ


def test_explicit_image_size() -> None:
    assert meta_backend("resnet50", image_size=[200, 300]).preprocess(image(90, 100)).shape == (3, 200, 300)
    assert meta_backend("dinov2", image_size=[224, 308]).preprocess(image(90, 100)).shape == (3, 224, 308)
    with pytest.raises(ValueError, match="RGB uint8"):
        meta_backend("resnet50").preprocess(np.zeros((10, 10), dtype=np.uint8))
