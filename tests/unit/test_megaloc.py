"""MegaLoc backend: official key lists, exact maths against naive re-implementations, eval mode, non-square
inputs, both checkpoint formats (safetensors and the earlier megaloc.torch) and the wrong-file messages."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest
import torch
import torch.nn.functional as F
from helpers import TESTS
from oracles import naive_aggregate, naive_vit_tokens
from safetensors.torch import save_file

from vpr_smr.descriptors import backend_class, extract
from vpr_smr.descriptors.base import CheckpointError
from vpr_smr.descriptors.dinov2 import interpolate_pos_embed
from vpr_smr.descriptors.megaloc import MegaLoc, MegaLocAggregator, MegaLocNet, from_megaloc_torch
from vpr_smr.pipeline.cli import main

KEYS_FILE = TESTS / "data" / "keys" / "megaloc_model_safetensors.json"
EARLIER_KEYS_FILE = TESTS / "data" / "keys" / "megaloc_megaloc_torch.json"

TINY = {"embed_dim": 16, "depth": 2, "num_heads": 2, "num_clusters": 4, "cluster_dim": 3, "token_dim": 5,
        "mlp_dim": 6, "feat_dim": 7}
TINY_IMAGE = [42, 56]  # 3 x 4 patches: more local features (12) than clusters (4), as Sinkhorn needs
TINY_OPTIONS = [item for key, value in {**TINY, "image_size": TINY_IMAGE, "device": "cpu"}.items()
                for item in ("--option", f"{key}={json.dumps(value)}")]
IMAGENET = ([0.485, 0.456, 0.406], [0.229, 0.224, 0.225])


def tiny_backend(**settings: object) -> MegaLoc:
    return MegaLoc({**TINY, "image_size": TINY_IMAGE, "device": "cpu", **settings})


def tiny_net() -> MegaLocNet:
    net_settings = {k: v for k, v in TINY.items()}
    return MegaLocNet(**net_settings).eval()


def random_state_dict(model: torch.nn.Module, seed: int = 0) -> dict[str, torch.Tensor]:
    generator = torch.Generator().manual_seed(seed)
    return {k: torch.randn(v.shape, generator=generator) * (0.3 if v.ndim > 1 else 1.0)
            for k, v in model.state_dict().items()}


def earlier_layout(state_dict: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    """``state_dict`` as megaloc.torch stores it: the ViT under ``backbone.model.*``, with ``mask_token``."""
    renamed = {k.replace("backbone.", "backbone.model.", 1): v for k, v in state_dict.items()}
    dim = state_dict["backbone.cls_token"].shape[-1]
    return {"backbone.model.mask_token": torch.zeros(1, dim), **renamed}


# ---------------------------------------------------------------- official key lists


def test_registry_resolves_megaloc() -> None:
    assert backend_class("megaloc") is MegaLoc


def test_state_dict_matches_official_keys() -> None:
    with torch.device("meta"):  # shapes only
        backend = MegaLoc({"device": "cpu"})
    official = json.loads(KEYS_FILE.read_text())
    ours = {k: list(v.shape) for k, v in backend.model.state_dict().items()}
    assert ours == official
    assert list(ours) == list(official)  # the official order too
    assert len(ours) == 189 and not any("mask_token" in k for k in ours)
    assert ours["aggregator.linear.weight"] == [8448, 256 + 64 * 256]


def test_earlier_release_keys_map_onto_ours() -> None:
    earlier = json.loads(EARLIER_KEYS_FILE.read_text())
    assert len(earlier) == 190 and earlier["backbone.model.mask_token"] == [1, 768]
    assert from_megaloc_torch(earlier) == json.loads(KEYS_FILE.read_text())


def test_mixed_layouts_are_refused() -> None:
    with pytest.raises(CheckpointError, match="mixes MegaLoc's two layouts"):
        from_megaloc_torch({"backbone.model.cls_token": 1, "backbone.norm.weight": 2})


def test_descriptor_size_and_norm_at_full_width() -> None:
    # The released sizes except the ViT's depth (2 blocks instead of 12, for time): 8448 values of unit norm.
    torch.manual_seed(0)
    backend = MegaLoc({"depth": 2, "device": "cpu"})
    image = np.random.default_rng(0).integers(0, 256, (240, 320, 3), dtype=np.uint8)
    batch = backend.preprocess(image)[None]
    assert tuple(batch.shape) == (1, 3, 322, 322)
    descriptor = backend.forward(batch)
    assert descriptor.shape == (1, 8448) and descriptor.dtype == np.float32 and np.isfinite(descriptor).all()
    assert np.linalg.norm(descriptor[0]) == pytest.approx(1.0, abs=1e-5)


# ---------------------------------------------------------------- preprocessing and the forward's resizing


def harness_transform(image: np.ndarray, size: list[int] | None) -> torch.Tensor:
    """VPR-methods-evaluation's test_dataset.py: ToTensor, Normalize, then Resize(size, antialias=True) if a
    size is given (--image_size)."""
    import torchvision.transforms as T
    from PIL import Image

    steps = [T.ToTensor(), T.Normalize(*IMAGENET)]
    if size:
        steps.append(T.Resize(size=size, antialias=True))
    result: torch.Tensor = T.Compose(steps)(Image.fromarray(image))
    return result


@pytest.mark.parametrize("shape", [(240, 320, 3), (500, 380, 3), (322, 322, 3)])
def test_preprocess_official_322(shape: tuple[int, int, int]) -> None:
    image = np.random.default_rng(1).integers(0, 256, shape, dtype=np.uint8)
    ours = MegaLoc({**TINY, "device": "cpu"}).preprocess(image)
    assert ours.shape == (3, 322, 322)
    torch.testing.assert_close(ours, harness_transform(image, [322, 322]), rtol=0, atol=1e-6)


def test_preprocess_vpr_methods_evaluation() -> None:
    # The harness feeds MegaLoc the full normalised image; MegaLoc's forward resizes it to [98, 154].
    import torchvision.transforms.functional as TF

    image = np.random.default_rng(5).integers(0, 256, (100, 150, 3), dtype=np.uint8)
    expected = TF.resize(harness_transform(image, None)[None], [98, 154], antialias=True)[0]
    harness = MegaLoc({**TINY, "device": "cpu", "preprocessing": "vpr-methods-evaluation"})
    ours = harness.preprocess(image)
    assert ours.shape == (3, 98, 154)
    torch.testing.assert_close(ours, expected, rtol=0, atol=1e-6)
    fixed = MegaLoc({**TINY, "device": "cpu", "preprocessing": "vpr-methods-evaluation", "image_size": [42, 56]})
    assert fixed.preprocess(image).shape == (3, 42, 56)  # an explicit size wins over both presets
    with pytest.raises(ValueError, match="megaloc: a 6 x 30 image rounds to 0 x 28: too small"):
        harness.preprocess(np.zeros((6, 30, 3), dtype=np.uint8))


def test_image_size_setting_is_checked() -> None:
    with pytest.raises(ValueError, match="image_size must be auto or"):
        MegaLoc({**TINY, "image_size": [322], "device": "cpu"})
    with pytest.raises(CheckpointError, match="model.safetensors"):
        tiny_backend().load(None)


def test_forward_resizes_to_multiples_of_14_as_official() -> None:
    import torchvision.transforms.functional as TF

    model = tiny_net()
    model.load_state_dict(random_state_dict(model, seed=1))
    images = torch.randn(2, 3, 45, 60, generator=torch.Generator().manual_seed(2))
    with torch.no_grad():
        ours = model(images)
        # megaloc_model.py: round(45 / 14) * 14 = 42, round(60 / 14) * 14 = 56, tfm.resize(..., antialias=True).
        expected = model(TF.resize(images, [42, 56], antialias=True))
    assert torch.equal(ours, expected)


# ---------------------------------------------------------------- non-square inputs and the whole network


@pytest.mark.parametrize(("height", "width"), [(42, 70), (70, 42)])
def test_non_square_position_embedding_as_dinov2(height: int, width: int) -> None:
    model = tiny_net()
    model.load_state_dict(random_state_dict(model, seed=3))
    vit = model.backbone
    grid_h, grid_w = height // 14, width // 14
    ours = vit.interpolate_pos_encoding(1 + grid_h * grid_w, height, width)
    table = vit.pos_embed[:, 1:].reshape(1, 37, 37, -1).permute(0, 3, 1, 2)
    # DINOv2: rows scaled by (h + 0.1) / 37, columns by (w + 0.1) / 37, bicubic, no antialias; row-major.
    direct = F.interpolate(table, scale_factor=((grid_h + 0.1) / 37, (grid_w + 0.1) / 37), mode="bicubic",
                           antialias=False)
    assert tuple(direct.shape[-2:]) == (grid_h, grid_w)
    assert torch.equal(ours[:, 1:], direct.permute(0, 2, 3, 1).reshape(1, grid_h * grid_w, -1))
    assert torch.equal(ours[:, 1:], interpolate_pos_embed(vit.pos_embed, grid_h, grid_w)[:, 1:])
    # MegaLoc's code before 4a23a2b passed (W, H): a (w, h) grid flattened as if it were (h, w).
    swapped = F.interpolate(table, scale_factor=((grid_w + 0.1) / 37, (grid_h + 0.1) / 37), mode="bicubic",
                            antialias=False)
    assert (swapped.permute(0, 2, 3, 1).reshape(1, grid_h * grid_w, -1) - ours[:, 1:]).abs().max() > 1e-2


def naive_megaloc(params: dict[str, np.ndarray], features: np.ndarray, token: np.ndarray) -> np.ndarray:
    """MegaLoc's aggregator on one image, before the final L2: ``features`` ``(n, C)`` patch tokens, ``token``
    ``(C,)``; SALAD's aggregation written out (``oracles.naive_aggregate``, on the ``agg.*`` parameters), then
    the linear map."""
    salad = naive_aggregate({k.removeprefix("agg."): v for k, v in params.items() if k.startswith("agg.")},
                            features, token)
    projected: np.ndarray = params["linear.weight"] @ salad + params["linear.bias"]
    return projected


def test_aggregation_matches_naive() -> None:
    torch.manual_seed(5)
    aggregator = MegaLocAggregator(num_channels=8, num_clusters=4, cluster_dim=3, token_dim=5, mlp_dim=6,
                                   feat_dim=7).eval()
    with torch.no_grad():
        aggregator.agg.dust_bin.fill_(0.4)
    features = torch.randn(2, 8, 3, 4)
    token = torch.randn(2, 8)
    with torch.no_grad():
        ours = aggregator(features, token).numpy()
    assert ours.shape == (2, 7)
    params = {k: v.double().numpy() for k, v in aggregator.state_dict().items()}
    for b in range(2):
        local = features[b].flatten(1).T.double().numpy()  # (n, C), row-major patches
        expected = naive_megaloc(params, local, token[b].double().numpy())
        np.testing.assert_allclose(ours[b], expected, atol=1e-6)


@pytest.mark.parametrize("size", [(42, 70), (70, 42), (42, 56)])
def test_tiny_network_matches_naive_implementation(size: tuple[int, int]) -> None:
    model = tiny_net()
    sd = random_state_dict(model, seed=6)
    model.load_state_dict(sd)
    images = torch.randn(2, 3, *size, generator=torch.Generator().manual_seed(7))
    with torch.no_grad():
        ours = model(images).numpy()
    # test_salad's written-out DINOv2 reads the hub layout: give it our ViT under backbone.model.*.
    sd64 = {k.replace("backbone.", "backbone.model.", 1): v.double() for k, v in sd.items()}
    params = {k.removeprefix("aggregator."): v.numpy() for k, v in sd64.items() if k.startswith("aggregator.")}
    for b in range(2):
        tokens = naive_vit_tokens(sd64, images[b].double(), TINY["depth"], TINY["num_heads"]).numpy()
        expected = naive_megaloc(params, tokens[1:], tokens[0])
        np.testing.assert_allclose(ours[b], expected / np.linalg.norm(expected), atol=2e-5)
        assert np.linalg.norm(ours[b]) == pytest.approx(1.0, abs=1e-6)


def test_backend_runs_in_eval_mode(tmp_path: Path) -> None:
    reference = tiny_net()
    save_file(random_state_dict(reference, seed=8), tmp_path / "model.safetensors")
    backend = tiny_backend()
    assert not backend.model.training
    backend.load(tmp_path / "model.safetensors")
    assert not any(module.training for module in backend.model.modules())
    image = np.random.default_rng(9).integers(0, 256, (60, 80, 3), dtype=np.uint8)
    batch = backend.preprocess(image)[None]
    first, second = backend.forward(batch), backend.forward(batch)
    assert np.array_equal(first, second)
    # The aggregation has dropout: in training mode (how the official loader returns the model) it differs.
    backend.model.train()
    torch.manual_seed(0)
    assert not np.array_equal(backend.forward(batch), first)


# ---------------------------------------------------------------- checkpoint loading


def test_round_trip_safetensors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    reference = tiny_net()
    sd = random_state_dict(reference, seed=10)
    reference.load_state_dict(sd)
    path = tmp_path / "model.safetensors"
    save_file(sd, path)
    backend = tiny_backend()
    backend.load(path)
    assert backend.checkpoint_file == path
    images = [np.random.default_rng(11 + i).integers(0, 256, (60, 80, 3), dtype=np.uint8) for i in range(2)]
    batch = torch.stack([backend.preprocess(image) for image in images])
    ours = backend.forward(batch)
    with torch.no_grad():
        expected = reference(batch).numpy()
    assert ours.shape == (2, 7) and ours.dtype == np.float32
    np.testing.assert_allclose(ours, expected, rtol=0, atol=1e-6)
    # The preflight's check (meta device) and `vpr-smr checkpoint check` accept it.
    conf = {"backend": "megaloc", **TINY, "image_size": TINY_IMAGE, "device": "cpu", "checkpoint": str(path)}
    digest = extract.check_checkpoint(conf, method="megaloc")
    assert digest is not None and len(digest) == 64
    assert main(["checkpoint", "check", "megaloc", str(path), *TINY_OPTIONS]) == 0
    assert "descriptor size 7" in capsys.readouterr().out


def test_earlier_release_loads_directly(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    reference = tiny_net()
    sd = random_state_dict(reference, seed=12)
    reference.load_state_dict(sd)
    path = tmp_path / "megaloc.torch"
    torch.save(earlier_layout(sd), path)  # a plain state dict: weights_only=True reads it
    backend = tiny_backend()
    with caplog.at_level(logging.INFO, logger="vpr_smr.descriptors.megaloc"):
        backend.load(path)
    assert "layout of the earlier release megaloc.torch" in caplog.text
    assert "renamed to backbone.*" in caplog.text and "no conversion needed" in caplog.text
    batch = torch.randn(2, 3, *TINY_IMAGE, generator=torch.Generator().manual_seed(13))
    with torch.no_grad():
        expected = reference(batch).numpy()
    np.testing.assert_allclose(backend.forward(batch), expected, rtol=0, atol=1e-6)


def wrong_state_dict() -> dict[str, torch.Tensor]:
    sd = random_state_dict(tiny_net())
    del sd["backbone.norm.bias"]
    sd["aggregator.extra"] = torch.zeros(2)
    sd["aggregator.linear.bias"] = torch.zeros(9)
    return sd


@pytest.mark.parametrize("kind", ["safetensors", "torch"])
def test_wrong_file_names_keys_and_expected_file(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                 kind: str) -> None:
    path = tmp_path / ("model.safetensors" if kind == "safetensors" else "other.pth")
    if kind == "safetensors":
        save_file(wrong_state_dict(), path)
    else:
        torch.save(wrong_state_dict(), path)
    with pytest.raises(CheckpointError) as error:
        tiny_backend().load(path)
    message = str(error.value)
    for expected in (f"checkpoint {path} does not fit backend 'megaloc'", "1 missing keys:\n    backbone.norm.bias",
                     "1 unexpected keys:\n    aggregator.extra",
                     "aggregator.linear.bias: file (9,), model (7,)", "the official model.safetensors of MegaLoc",
                     "megaloc.torch"):
        assert expected in message, message
    conf = {"backend": "megaloc", **TINY, "image_size": TINY_IMAGE, "device": "cpu", "checkpoint": str(path)}
    with pytest.raises(CheckpointError) as planned:
        extract.check_checkpoint(conf, method="m")  # the preflight's check
    assert str(planned.value) == message
    assert main(["checkpoint", "check", "megaloc", str(path), *TINY_OPTIONS]) == 1
    assert capsys.readouterr().err == f"NOT OK: {message}\n"


def test_wrong_file_in_the_earlier_layout_says_keys_were_renamed(tmp_path: Path) -> None:
    path = tmp_path / "megaloc.torch"
    torch.save(earlier_layout(wrong_state_dict()), path)
    with pytest.raises(CheckpointError) as error:
        tiny_backend().load(path)
    message = str(error.value)
    assert "1 missing keys:\n    backbone.norm.bias" in message
    assert "backbone.model.* keys were renamed to backbone.* (the layout of megaloc.torch)" in message


def test_salad_checkpoint_is_recognised(tmp_path: Path) -> None:
    from vpr_smr.descriptors.salad import SALADNet

    salad = SALADNet(embed_dim=16, depth=2, num_heads=2, num_clusters=4, cluster_dim=3, token_dim=5)
    path = tmp_path / "dino_salad.ckpt"
    torch.save(random_state_dict(salad), path)
    with pytest.raises(CheckpointError, match=r"SALAD's dino_salad.ckpt\? \(use backend salad for it\)"):
        tiny_backend().load(path)


def safetensors_bytes(tmp_path: Path) -> bytes:
    save_file({"a": torch.arange(100, dtype=torch.float32)}, tmp_path / "small.safetensors")
    return (tmp_path / "small.safetensors").read_bytes()


@pytest.mark.parametrize(("case", "findings"), [
    ("data_cut", ["is truncated", "its safetensors header announces", "download it again"]),
    ("header_cut", ["is truncated (30 bytes; its safetensors header alone announces", "download it again"]),
    ("damaged_header", ["is damaged or not a safetensors file (SafetensorError", "download it again"]),
    ("html", ["is text, not a checkpoint (it starts with '<!DOCTYPE html", "web page"]),
    ("empty", ["is empty (0 bytes)"]),
])
def test_unreadable_files_are_described(tmp_path: Path, case: str, findings: list[str]) -> None:
    content = safetensors_bytes(tmp_path)
    contents = {
        "data_cut": content[:-40],
        "header_cut": content[:30],
        "damaged_header": content[:8] + b"{" + b"x" * (int.from_bytes(content[:8], "little") - 1) + content[
            8 + int.from_bytes(content[:8], "little"):],
        "html": b"<!DOCTYPE html>\n<html><head><title>404 Not Found</title></head></html>\n",
        "empty": b"",
    }
    path = tmp_path / "model.safetensors"
    path.write_bytes(contents[case])
    with pytest.raises(CheckpointError) as error:
        tiny_backend().load(path)
    message = str(error.value)
    assert message.startswith(f"checkpoint {path} "), message
    for finding in findings + ["the official model.safetensors of MegaLoc"]:
        assert finding in message, message
    assert "weights_only=False" not in message


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(CheckpointError, match="checkpoint not found"):
        tiny_backend().load(tmp_path / "model.safetensors")


def test_no_conversion_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["convert-checkpoint", "megaloc", "megaloc.torch", "out.safetensors"]) == 2
    err = capsys.readouterr().err
    assert "no conversion for 'megaloc'" in err and "model.safetensors" in err and "megaloc.torch" in err


def test_full_size_earlier_release_passes_the_preflight_check(tmp_path: Path) -> None:
    # A megaloc.torch with the official keys and shapes whose tensors share one stored value (a few kB): the
    # preflight's check (meta device, nothing loaded) renames and checks all 190 keys of the full-size model.
    shapes = json.loads(EARLIER_KEYS_FILE.read_text())
    one = torch.zeros(1)
    path = tmp_path / "megaloc.torch"
    torch.save({key: one.expand(shape) if shape else one[0] for key, shape in shapes.items()}, path)
    assert extract.check_checkpoint({"backend": "megaloc", "device": "cpu", "checkpoint": str(path)}) is not None
    del shapes["backbone.model.blocks.11.ls2.gamma"]
    torch.save({key: one.expand(shape) if shape else one[0] for key, shape in shapes.items()}, path)
    with pytest.raises(CheckpointError, match=r"1 missing keys:\n    backbone.blocks.11.ls2.gamma"):
        extract.check_checkpoint({"backend": "megaloc", "device": "cpu", "checkpoint": str(path)})


def test_run_refuses_a_wrong_file_before_any_job(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "model.safetensors"
    save_file(wrong_state_dict(), path)
    settings = {"backend": "megaloc", "checkpoint": str(path), **TINY, "image_size": TINY_IMAGE, "device": "cpu"}
    config = tmp_path / "c.yaml"
    config.write_text(json.dumps({"run": "x", "output": str(tmp_path / "results"),
                                  "datasets": {"s": {"loader": "nordland_sample"}},
                                  "methods": {"megaloc": settings}}))
    assert main(["run", str(config)]) == 2
    err = capsys.readouterr().err
    assert f"checkpoint {path} does not fit backend 'megaloc'" in err
    assert "backbone.norm.bias" in err and "aggregator.extra" in err
    assert not (tmp_path / "results").exists()
