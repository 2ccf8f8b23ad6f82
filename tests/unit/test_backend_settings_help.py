"""Every built-in backend's settings have a meaning (``Backend.settings_help``), and so do the settings every backend
takes (``COMMON_SETTINGS_HELP``): one line per key, for the configuration reference. The spot checks hold each text
to what the code does with that setting, so a text written for another setting fails."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import pytest
import torch

from vpr_smr.core.settings import setting
from vpr_smr.descriptors import BACKENDS, backend_class
from vpr_smr.descriptors.base import COMMON_SETTINGS, COMMON_SETTINGS_HELP, Backend


def help_of(name: str) -> dict[str, str]:
    return backend_class(name).settings_help


def assert_one_line(key: str, text: str) -> None:
    assert text.strip(), f"{key}: empty"
    assert text == text.strip() and "\n" not in text and "  " not in text, f"{key}: not one clean line: {text!r}"
    assert not text.endswith("."), f"{key}: the reference's descriptions end without a period: {text!r}"


@pytest.mark.parametrize("name", sorted(BACKENDS))
def test_every_setting_of_every_builtin_backend_has_one_line(name):
    cls = backend_class(name)
    assert set(cls.settings_help) == set(cls.default_conf), name
    for key, text in cls.settings_help.items():
        assert_one_line(f"{name}.{key}", text)
        # the type is unclear from a null or auto default: the text names what is accepted
        if cls.default_conf[key] is None:
            assert "null" in text, f"{name}.{key}: the default is null but the text does not say what null does"
        if cls.default_conf[key] == "auto":
            assert "auto" in text and ("[H, W]" in text or "text" in text), f"{name}.{key}: {text!r}"


def test_common_settings_have_one_line_each():
    assert tuple(COMMON_SETTINGS_HELP) == COMMON_SETTINGS
    for key, text in COMMON_SETTINGS_HELP.items():
        assert_one_line(key, text)
    # the choices, written out here rather than taken from METRICS / PREPROCESSING
    for metric in ("l2", "cosine", "mad"):
        assert metric in COMMON_SETTINGS_HELP["distance"]
    for preset in ("official", "vpr-methods-evaluation"):
        assert preset in COMMON_SETTINGS_HELP["preprocessing"]
    assert "float16" in COMMON_SETTINGS_HELP["half"] and "CUDA" in COMMON_SETTINGS_HELP["half"]
    assert "cuda" in COMMON_SETTINGS_HELP["device"] and "cpu" in COMMON_SETTINGS_HELP["device"]
    assert "weights file" in COMMON_SETTINGS_HELP["checkpoint"]


def test_the_common_defaults_are_what_the_help_says():
    sad = backend_class("sad")({"distance": None, "preprocessing": None, "device": None})
    assert "the backend's own metric" in COMMON_SETTINGS_HELP["distance"] and sad.distance == "mad"
    assert "official (the default, also for null)" in COMMON_SETTINGS_HELP["preprocessing"]
    assert sad.conf["preprocessing"] == "official"
    assert sad.device.type == ("cuda" if torch.cuda.is_available() else "cpu")
    assert "(default false)" in COMMON_SETTINGS_HELP["half"] and sad.half is False
    assert backend_class("sad")({"half": True, "device": "cpu"}).half is False  # "ignored on the CPU"


def test_a_backend_declares_its_settings_as_a_record():
    """``Settings`` (``core.settings.setting`` fields) gives ``default_conf`` as JSON (a list for a tuple), in
    declaration order, and ``settings_help``; a subclass inherits them, or overrides a field in its place."""

    @dataclass(frozen=True)
    class SizeSettings:
        size: tuple[int, ...] = setting((2, 3), "[H, W]: the size")
        scale: float = setting(1.0, "a factor")

    class Sized(Backend):
        name: ClassVar[str] = "sized_plugin"
        Settings: ClassVar[type | None] = SizeSettings

        def preprocess(self, image: np.ndarray) -> torch.Tensor:
            return torch.full(tuple(self.conf["size"]), float(image.mean()) * self.conf["scale"])

        def forward(self, batch: torch.Tensor) -> np.ndarray:
            return batch.flatten(1).numpy()

    @dataclass(frozen=True)
    class LargerSettings(SizeSettings):
        size: tuple[int, ...] = setting((1, 1), "[H, W]: one pixel")

    class Larger(Sized):
        Settings: ClassVar[type | None] = LargerSettings

    class Same(Sized):
        pass

    assert Sized.default_conf == {"size": [2, 3], "scale": 1.0} and list(Sized.default_conf) == ["size", "scale"]
    assert Sized.settings_help == {"size": "[H, W]: the size", "scale": "a factor"}
    assert Same.default_conf == Sized.default_conf and Same.settings_help == Sized.settings_help
    assert Larger.default_conf == {"size": [1, 1], "scale": 1.0} and Larger.settings_help["size"] == "[H, W]: one pixel"
    assert Sized({"scale": 2.0}).describe(np.full((2, 2, 3), 6, np.uint8)).tolist() == [12.0] * 6
    with pytest.raises(ValueError, match="backend 'sized_plugin' has no setting scael; its settings are scale, size"):
        Sized({"scael": 2.0})


def test_a_plugin_backend_of_0_15_with_dicts_still_works_and_is_told_the_new_way():
    with pytest.warns(DeprecationWarning, match=r"descriptor backend .*Plain declares its settings as default_conf "
                                                r"and settings_help dicts.*a Settings record of "
                                                r"core.settings.setting\(default, help\) fields"):
        class Plain(Backend):
            name: ClassVar[str] = "plain_plugin"
            default_conf: ClassVar[dict[str, Any]] = {"k": 2}

            def preprocess(self, image: np.ndarray) -> torch.Tensor:
                return torch.full((self.conf["k"],), float(image.mean()))

            def forward(self, batch: torch.Tensor) -> np.ndarray:
                return batch.numpy()

    assert Plain.settings_help == {} and Backend.settings_help == {}
    assert Plain({"k": 3}).describe(np.full((2, 2, 3), 6, np.uint8)).tolist() == [6.0, 6.0, 6.0]


def test_no_builtin_backend_declares_dicts():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        for name in BACKENDS:
            assert backend_class(name).Settings is not None, name


def test_sad_patch_is_the_side_of_the_normalised_blocks():
    text = help_of("sad")
    assert "patch normalisation" in text["patch"] and "zero mean" in text["patch"]
    assert "width" in text["width"] and "multiple of patch" in text["width"]
    assert "height" in text["height"] and "patch normalisation" not in text["width"] + text["height"]
    # what the text claims, in the code: with patch 4, every 4 x 4 block of the 64 x 32 thumbnail has mean 0 and
    # (population) std 1; with the default 8 the same 4 x 4 blocks do not
    image = np.random.default_rng(0).integers(0, 256, (48, 96, 3), dtype=np.uint8)
    for patch, exact in ((4, True), (8, False)):
        thumbnail = backend_class("sad")({"patch": patch}).describe(image).reshape(32, 64).astype(np.float64)
        blocks = thumbnail.reshape(8, 4, 16, 4).transpose(0, 2, 1, 3).reshape(-1, 16)
        assert np.allclose(blocks.mean(axis=1), 0, atol=1e-5) is exact
        assert np.allclose(blocks.std(axis=1), 1, atol=1e-5) is exact


def test_hog_texts_name_their_own_setting():
    text = help_of("hog")
    assert "orientation bins" in text["bins"] and "180 degrees" in text["bins"]
    assert "block stride" in text["cell"] and "histogram" in text["cell"]
    assert "normalised together" in text["block"] and "multiple of cell" in text["block"]
    assert "width" in text["width"] and "height" in text["height"]


def test_learned_backends_texts_name_their_own_setting():
    netvlad = help_of("netvlad")
    assert "480 x 640" in netvlad["image_size"] and "full size" in netvlad["image_size"]  # Patch-NetVLAD's configs
    assert "pool.centroids" in netvlad["num_clusters"] and "WPCA" in netvlad["num_pcs"]
    apgem = help_of("apgem")
    assert "Landmarks_clean" in apgem["whiten"] and "0.25" in apgem["whitenp"]
    assert "components kept" in apgem["whitenv"] and "longest image side" in apgem["max_size"]
    assert "whitenm x variance ^ whitenp" in apgem["whitenm"]
    cosplace, eigenplaces = help_of("cosplace"), help_of("eigenplaces")
    assert "ResNet152" in cosplace["backbone"] and "ResNet152" not in eigenplaces["backbone"]  # EigenPlaces' releases
    assert "shorter side" in cosplace["resize"] and "bicubic" in cosplace["interpolation"]
    assert "aggregation.3" in cosplace["fc_output_dim"]
    mixvpr = help_of("mixvpr")
    assert "channel_proj" in mixvpr["out_channels"] and "1024 for 4096-d" in mixvpr["out_channels"]
    assert "row_proj" in mixvpr["out_rows"] and "4 for 4096-d" in mixvpr["out_rows"]
    assert "320 x 320" in mixvpr["image_size"]
    boq = help_of("boq")
    assert "384 x 384 for resnet50" in boq["image_size"] and "322 x 322 for dinov2" in boq["image_size"]
    assert "16384 for resnet50" in boq["output_dim"] and "backbone.dino.*" in boq["backbone"]
    salad, megaloc = help_of("salad"), help_of("megaloc")
    for text in (salad, megaloc):
        assert "322 x 322" in text["image_size"] and "multiple of 14" in text["image_size"]
        assert "ViT-B/14" in text["embed_dim"] and "blocks" in text["depth"] and "heads" in text["num_heads"]
        assert "class token" in text["token_dim"] and "dustbin" in text["num_clusters"]
    assert "aggregator.linear" in megaloc["feat_dim"] and "hidden size" in megaloc["mlp_dim"]
    lite = help_of("efficientnet_lite0_gem")
    assert "GeM" in lite["gem_p"] and "[H, W]" in lite["image_size"]
    precomputed = help_of("precomputed")
    assert "database_descriptors.npy" in precomputed["folder"] and "queries_descriptors.npy" in precomputed["folder"]
    assert "reference descriptors" in precomputed["database"] and "query descriptors" in precomputed["queries"]
