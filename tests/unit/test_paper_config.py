"""configs/paper.yaml: fails at once while roots and checkpoints are empty; its commented methods are valid
(the dry run of 3 datasets x 7 methods: test_paper_config_workflow.py)."""

import yaml
from paper_run import METHODS, PAPER, shaped_checkpoint

from vpr_smr.pipeline.cli import main


def test_empty_settings_are_named(capsys):
    assert main(["run", str(PAPER), "-n"]) == 2
    err = capsys.readouterr().err
    for name in ("nordland", "robotcar", "sfu_mountain"):
        assert f"datasets.{name}.root is not set" in err
    for method in METHODS:
        if method != "sad":
            assert f"methods.{method}.checkpoint is not set" in err
    assert "methods.sad" not in err


def test_the_commented_current_methods_are_valid_entries(tmp_path):
    # configs/paper.yaml lists MegaLoc and BoQ commented out (the paper did not use them): uncommented, with files
    # of the official keys and shapes, each entry passes the check the run does before its first job.
    from vpr_smr.descriptors.extract import check_checkpoint

    text = PAPER.read_text()
    block = text[text.index("  # megaloc:"):]
    uncommented = "\n".join(line.replace("  # ", "  ", 1) for line in block.splitlines())
    methods = yaml.safe_load("methods:\n" + uncommented)["methods"]
    assert list(methods) == ["megaloc", "boq"]
    files = {"megaloc": "megaloc_model_safetensors", "boq": "boq_dinov2_12288"}
    for name, settings in methods.items():
        settings["checkpoint"] = str(shaped_checkpoint(tmp_path / f"{name}.pth", files[name]))
        assert len(check_checkpoint(settings, name)) == 64  # the file's SHA-256
