"""Checkpoint errors say what the file is and how to fix it, the same in `vpr-smr checkpoint check`, the
configuration check (``check_checkpoint``) and the descriptors job (``build_backend``)."""

from __future__ import annotations

import argparse
import io
import json
import struct
import tarfile
import zipfile
from pathlib import Path

import pytest
import torch

from vpr_smr.descriptors import cosplace, extract
from vpr_smr.descriptors.base import CheckpointError
from vpr_smr.pipeline.cli import main

# ResNet18 CosPlace: the cheapest real backend that loads a torch.save state dict (no converter).
COSPLACE = {"backend": "cosplace", "backbone": "ResNet18", "device": "cpu"}
CLI_OPTIONS = ["--option", "backbone=ResNet18", "--option", "device=cpu"]


def checked(conf: dict, path: Path) -> str:
    """The configuration check's message for ``path`` (what the pipeline shows before the first job)."""
    with pytest.raises(CheckpointError) as info:
        extract.check_checkpoint({**conf, "checkpoint": str(path)}, method="m")
    return str(info.value)


def cli(capsys, *argv: str) -> tuple[int, str]:
    status = main(list(argv))
    return status, capsys.readouterr().err


def torch_bytes(obj, zip_format: bool = True) -> bytes:
    buffer = io.BytesIO()
    torch.save(obj, buffer, _use_new_zipfile_serialization=zip_format)
    return buffer.getvalue()


def small_state() -> dict[str, torch.Tensor]:
    return {"a.weight": torch.arange(600, dtype=torch.float32), "b.bias": torch.ones(40)}


def safetensors_bytes() -> bytes:
    """A safetensors file written by hand from its specification: u64 header length, JSON header, raw data."""
    header = json.dumps({"a.weight": {"dtype": "F32", "shape": [2], "data_offsets": [0, 8]}}).encode()
    return struct.pack("<Q", len(header)) + header + struct.pack("<2f", 1.0, 2.0)


def tar_bytes() -> bytes:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w") as archive:
        data = torch_bytes(small_state())
        info = tarfile.TarInfo("inner.pth")
        info.size = len(data)
        archive.addfile(info, io.BytesIO(data))
    return buffer.getvalue()


def zip_bytes() -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("readme.txt", "weights inside")
        archive.writestr("model.pth", b"x")
    return buffer.getvalue()


ZIP_STATE = torch_bytes(small_state())
LEGACY_STATE = torch_bytes(small_state(), zip_format=False)

# name -> (file content, what every message must say about it)
CASES = {
    "empty": (b"", ["is empty (0 bytes)", "download it again"]),
    "html": (b"<!DOCTYPE html>\n<html><head><title>404 Not Found</title></head></html>\n",
             ["is text, not a checkpoint (it starts with '<!DOCTYPE html", "web page", "download"]),
    "git_lfs": (b"version https://git-lfs.github.com/spec/v1\noid sha256:4d7a2146\nsize 104857600\n",
                ["is text, not a checkpoint", "git-lfs pointer", "`git lfs pull`"]),
    "truncated_zip": (ZIP_STATE[: len(ZIP_STATE) // 2],
                      ["is truncated", f"({len(ZIP_STATE) // 2} bytes", "download it again"]),
    "truncated_legacy": (LEGACY_STATE[:100], ["is truncated", "(100 bytes", "download it again"]),
    "truncated_legacy_data": (LEGACY_STATE[:-50], ["is truncated", "download it again"]),
    "python_objects": (torch_bytes({"args": argparse.Namespace(lr=0.1), "state_dict": small_state()}),
                       ["stores Python objects", "weights_only=True refuses argparse.Namespace",
                        "torch.save(model.state_dict(), PATH)"]),
    "safetensors": (safetensors_bytes(), ["is a safetensors file, not a torch.save checkpoint"]),
    "tar": (tar_bytes(), ["is a tar archive holding inner.pth", "tar -xf", "set `checkpoint` to the checkpoint"]),
    "zip": (zip_bytes(), ["is a zip archive holding readme.txt, model.pth", "unzip it"]),
    "no_state_dict": (torch_bytes({"epoch": 3, "best_recall": 0.5}),
                      ["holds no state dict", "a dict with keys epoch, best_recall"]),
    "nested_state_dict": (torch_bytes({"epoch": 3, "net": small_state()}),
                          ["holds no state dict", "its 'net' entry holds tensors", "weights_only=True)['net']"]),
    "empty_state_dict": (torch_bytes({"epoch": 3, "state_dict": {}}),
                         ["holds no state dict", "its 'state_dict' entry is an empty dict"]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_message_names_the_file_and_the_finding(tmp_path, capsys, case):
    content, findings = CASES[case]
    path = tmp_path / f"{case}.pth"
    path.write_bytes(content)
    message = checked(COSPLACE, path)
    status, err = cli(capsys, "checkpoint", "check", "cosplace", str(path), *CLI_OPTIONS)
    assert status == 1 and err.startswith("NOT OK: ")
    for text in (message, err):
        assert f"checkpoint {path} " in text, text
        for finding in findings:
            assert finding in text, text
        # cosplace has no converter; nothing advises unsafe loading; torch's raw complaints stay out.
        assert "convert-checkpoint" not in text
        assert "weights_only=False" not in text and "add_safe_globals" not in text
        assert "pop from empty list" not in text and "Unsupported operand" not in text
        assert "ResNet18_<dim>_cosplace.pth" in text  # the file the backend expects


def test_same_message_in_the_check_the_job_and_the_command(tmp_path, capsys):
    path = tmp_path / "page.pth"
    path.write_bytes(b"<html><body>Sign in to continue</body></html>")
    planned = checked(COSPLACE, path)  # what the configuration check reports before the first job
    with pytest.raises(CheckpointError) as info:
        extract.build_backend("m", {**COSPLACE, "checkpoint": str(path)})  # what the descriptors job raises
    status, err = cli(capsys, "checkpoint", "check", "cosplace", str(path), *CLI_OPTIONS)
    assert planned == str(info.value) == err.removeprefix("NOT OK: ").rstrip("\n")
    assert status == 1


def test_wrong_keys_are_still_listed(tmp_path, capsys):
    state = cosplace.GeoLocalizationNet("ResNet18", 64).state_dict()
    del state["aggregation.1.p"]
    path = tmp_path / "edited.pth"
    torch.save(state, path)
    status, err = cli(capsys, "checkpoint", "check", "cosplace", str(path), *CLI_OPTIONS)
    assert status == 1
    assert f"checkpoint {path} does not fit backend 'cosplace'" in err
    assert "1 missing keys:\n    aggregation.1.p" in err


def test_conversion_hint_only_for_a_backend_with_a_converter(tmp_path, capsys):
    path = tmp_path / "Resnet-101-AP-GeM.pt"
    path.write_bytes(CASES["python_objects"][0])
    apgem = checked({"backend": "apgem", "device": "cpu"}, path)
    assert f"checkpoint {path} stores Python objects" in apgem
    assert f"convert it first with `vpr-smr convert-checkpoint apgem {path} OUT`" in apgem
    for conf in (COSPLACE, {"backend": "netvlad", "device": "cpu"}):
        message = checked(conf, path)
        assert "stores Python objects" in message and "argparse.Namespace" in message
        assert "convert" not in message and "weights_only=False" not in message
    netvlad = checked({"backend": "netvlad", "device": "cpu"}, path)
    assert "pitts_WPCA4096.pth.tar" in netvlad  # the official file instead of a conversion


def test_convert_command_for_a_method_without_converter(capsys):
    status, err = cli(capsys, "convert-checkpoint", "cosplace", "in.pth", "out.pth")
    assert status == 2
    assert err.startswith("vpr-smr convert-checkpoint: error: no conversion for 'cosplace'")
    assert "loads its file as it is" in err and "_cosplace.pth" in err
    assert "vpr-smr checkpoint check cosplace FILE" in err and "apgem only" in err
    status, err = cli(capsys, "convert-checkpoint", "sad", "in.pth", "out.pth")
    assert status == 2 and "backend 'sad' takes no checkpoint file" in err


def test_convert_command_says_what_the_input_is(tmp_path, capsys):
    page = tmp_path / "Resnet-101-AP-GeM.pt"
    page.write_bytes(b"<!DOCTYPE html><html>Too many requests</html>")
    out = tmp_path / "apgem.pt"
    status, err = cli(capsys, "convert-checkpoint", "apgem", str(page), str(out))
    assert status == 2
    assert f"cannot convert {page}: it is text, not a checkpoint (it starts with '<!DOCTYPE html" in err
    empty = tmp_path / "empty.pt"
    empty.write_bytes(b"")
    status, err = cli(capsys, "convert-checkpoint", "apgem", str(empty), str(out))
    assert status == 2 and f"cannot convert {empty}: it is empty (0 bytes)" in err
    assert set(tmp_path.iterdir()) == {empty, page}  # nothing written, not even a temporary file
