import os

import pytest

# Tests share two cores with nothing else: keep torch and BLAS from oversubscribing.
os.environ.setdefault("OMP_NUM_THREADS", "1")


@pytest.fixture(autouse=True, scope="session")
def _torch_threads():
    import torch

    torch.set_num_threads(1)


@pytest.fixture
def pair(tmp_path):
    """Ten summer and ten winter frames of the shipped sample (1000-1090) as a `folders` pair, split `all`."""
    import shutil

    from vpr_smr.datasets.folders import folder_pair
    from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

    for season in ("summer", "winter"):
        (tmp_path / season).mkdir()
        for n in range(1000, 1100, 10):
            shutil.copy(DEFAULT_ROOT / season / f"images-{n:05d}.png", tmp_path / season)
    return folder_pair("mini", tmp_path / "summer", tmp_path / "winter", {"all": (0, 10)})


@pytest.fixture
def colour_frames(tmp_path):
    """Two folders of 24 solid-colour frames, each its own colour (``helpers.reference_colour`` and
    ``query_colour``), and their `folders` settings."""
    import cv2
    import numpy as np
    from helpers import COLOUR_FRAMES, query_colour, reference_colour

    settings = {"loader": "folders"}
    for side, colour in (("reference", reference_colour), ("query", query_colour)):
        folder = tmp_path / side
        folder.mkdir()
        for i in range(COLOUR_FRAMES):
            image = np.zeros((8, 16, 3), dtype=np.uint8)
            image[:] = colour(i)
            cv2.imwrite(str(folder / f"frame{i:03d}.png"), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
        settings[side] = str(folder)
    return settings


@pytest.fixture(scope="session")
def predictor_file(tmp_path_factory):
    """A predictor trained at L = 3 on frames 0..47 of dataset "d" (``training_sets.train_predictor``), trained once;
    tests only read it."""
    from training_sets import train_predictor

    return train_predictor(tmp_path_factory.mktemp("predictor"))


@pytest.fixture(scope="session")
def full_report_run(tmp_path_factory):
    """(run folder, files written) of ``report_runs.build_run`` with every experiment, the speed and matchers
    experiments' files, the experiment adaptive_seq_len's and a protocol sweep: dataset d, methods m1 and m2, L 2
    and 4, both modes; built once, tests only read it."""
    from deployment_results import deployment_files
    from report_runs import adaptive_files, build_run, matchers_files, speed_files

    folder = tmp_path_factory.mktemp("full_report_run")
    return build_run(folder, speed=speed_files(folder), matchers=matchers_files(folder),
                     adaptive=adaptive_files(folder), deployment=deployment_files(folder), sweep=True)
