"""configs/paper.yaml, its methods, and checkpoints with the official keys and shapes of the files it names (the
paper configuration's tests)."""

import json
from pathlib import Path

import torch
from helpers import REPO, TESTS

PAPER = REPO / "configs" / "paper.yaml"
METHODS = ("apgem", "cosplace", "eigenplaces", "mixvpr", "netvlad", "sad", "salad")
KEYS = TESTS / "data" / "keys"
# The official key lists (tests/data/keys/README.md) of the files that configs/paper.yaml names.
OFFICIAL_KEYS = {"apgem": "apgem_resnet101", "cosplace": "cosplace_ResNet50_2048",
                 "eigenplaces": "eigenplaces_ResNet50_2048", "mixvpr": "mixvpr_resnet50_4096",
                 "netvlad": "netvlad_patchnetvlad_wpca4096", "salad": "salad_dino_salad"}


def shaped_checkpoint(path: Path, keys: str) -> Path:
    """A checkpoint with the official keys and shapes whose tensors share one stored value (a few kB on disk):
    the run checks every key and shape before the first job, and a dry run computes nothing."""
    shapes = json.loads((KEYS / f"{keys}.json").read_text())
    one = torch.zeros(1)
    state_dict = {key: one.expand(shape) if shape else one[0] for key, shape in shapes.items()}
    if keys.startswith("apgem"):  # the converted layout (convert.convert_apgem), with the release's whitening
        whitening = {"mean": one.expand(2048), "components": one.expand(2048, 2048),
                     "explained_variance": one.expand(2048), "whiten": True}
        state_dict = {"state_dict": state_dict, "whitening": {"Landmarks_clean": whitening}}
    torch.save(state_dict, path)
    return path
