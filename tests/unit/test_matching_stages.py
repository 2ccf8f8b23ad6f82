"""The stages descriptors, distances and inspect as declared stages (``pipeline.stages.matching``): every option of
their earlier command lines gives the job record written here by hand, and ``--job`` with the record's text (what the
workflow's rules give) gives the same record back."""

import logging

import numpy as np
import pytest
from stage_jobs import check_old_command

from vpr_smr.eval.matching.distances import DistancesJob
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.sources import MatrixFormat, TruthSource
from vpr_smr.eval.report.inspector import InspectJob
from vpr_smr.pipeline.cli import build_parser
from vpr_smr.pipeline.cli import main as cli
from vpr_smr.pipeline.config import Extraction
from vpr_smr.pipeline.descriptors import DescriptorsJob
from vpr_smr.pipeline.stage import job_of, job_text
from vpr_smr.pipeline.stages import matching

DATASET = '{"loader": "folders", "reference": "a b/ref", "query": "q"}'
METHOD = '{"backend": "sad", "patch": 4}'

# (stage, the earlier command line with every option, the job it means)
OLD_COMMANDS = [
    (matching.DESCRIPTORS,
     ["descriptors", "--dataset", "route", "--dataset-settings", DATASET, "--frames-sha256", "f" * 64, "--method",
      "sad", "--method-settings", METHOD, "--threads", "2", "--batch-size", "8", "--num-workers", "0", "--out",
      "out dir/sad.h5"],
     DescriptorsJob("route", "sad", None, DATASET, METHOD, "f" * 64, Extraction(8, 0), 2, "out dir/sad.h5")),
    (matching.DESCRIPTORS,  # the settings from a configuration; the speed at its defaults
     ["descriptors", "--config", "my.yaml", "--dataset", "route", "--method", "sad", "--out", "sad.h5"],
     DescriptorsJob("route", "sad", "my.yaml", out="sad.h5")),
    (matching.DISTANCES,
     ["distances", "--descriptors", "d.h5", "--split", "val", "--frames", "2", "6", "--reference-frames", "0", "12",
      "--metric", "cosine", "--out", "val.h5"],
     DistancesJob("d.h5", "val", (2, 6), (0, 12), "cosine", "val.h5")),
    (matching.DISTANCES,  # the short form: one range, the descriptor file's metric
     ["distances", "--descriptors", "d.h5", "--split", "test", "--frames", "0", "40", "--out", "test.h5"],
     DistancesJob("d.h5", "test", (0, 40), out="test.h5")),
    (matching.INSPECT,
     ["inspect", "--queries", "q.csv", "--distances", "D.npz", "--matrix-figure", "d.png", "--match-figure", "m.png",
      "--dataset", "route", "--dataset-settings", DATASET, "--frames-sha256", "e" * 64, "--seq-len", "4", "--split",
      "test", "--tolerance", "3", "--matcher", "seqslam", "--velocities", "0.8", "1.0", "1.25",
      "--reference-positions", "r.csv", "--query-positions", "q.npy", "--radius", "7.5", "--ground-truth", "gt.mat",
      "--ground-truth-key", "GThard", "--similarity", "--key", "S", "--transpose", "--frames", "8", "24",
      "--per-class", "1", "--mistakes", "3", "--seed", "5"],
     InspectJob("q.csv", "D.npz", "m.png", "d.png", "route", DATASET, "e" * 64, 4, "test",
                TruthSource(3, "r.csv", "q.npy", 7.5, "gt.mat", "GThard"),
                MatcherSpec.of("seqslam", {"velocities": [0.8, 1.0, 1.25]}), MatrixFormat(True, "S", True), (8, 24),
                1, 3, 5)),
    (matching.INSPECT,  # a user's matrix, the distance-matrix figure only: the defaults of the others
     ["inspect", "--queries", "q.csv", "--distances", "D.npy", "--seq-len", "4", "--matrix-figure", "d.png"],
     InspectJob("q.csv", "D.npy", None, "d.png", seq_len=4)),
    (matching.INSPECT,  # another matcher and its settings
     ["inspect", "--queries", "q.csv", "--distances", "D.h5", "--seq-len", "3", "--matrix-figure", "d.png",
      "--matcher", "monotone", "--max-step", "3"],
     InspectJob("q.csv", "D.h5", None, "d.png", seq_len=3, matcher=MatcherSpec.of("monotone", {"max_step": 3}))),
]


@pytest.mark.parametrize("stage, argv, expected", OLD_COMMANDS,
                         ids=[f"{stage.command}-{i}" for i, (stage, _, _) in enumerate(OLD_COMMANDS)])
def test_the_old_command_lines_give_the_job(stage, argv, expected):
    check_old_command(stage, argv, expected)


@pytest.mark.parametrize("argv, message", [
    (["distances", "--descriptors", "d.h5", "--split", "val", "--frames", "2", "--out", "v.h5"],
     "--frames: .*give at least 2, got \\[2\\]"),
    (["distances", "--descriptors", "d.h5", "--split", "val", "--frames", "0", "4", "--reference-frames", "0", "4",
      "9", "--out", "v.h5"], "--reference-frames: .*give at most 2, got \\[0, 4, 9\\]"),
])
def test_a_range_is_two_frames(argv, message):
    with pytest.raises(ValueError, match=message):
        job_of(matching.DISTANCES, build_parser().parse_args(argv))


def test_a_metric_the_stage_does_not_know_is_refused(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["distances", "--descriptors", "d.h5", "--split", "val", "--frames", "0", "4",
                                   "--metric", "l1", "--out", "v.h5"])
    assert "invalid choice: 'l1'" in capsys.readouterr().err


def test_descriptors_needs_its_settings(tmp_path, capsys):
    """Neither --config nor both JSON objects: the error names the options, before the dataset is read."""
    assert cli(["descriptors", "--dataset", "d", "--method", "sad", "--dataset-settings", DATASET,
                "--out", str(tmp_path / "sad.h5")]) == 2
    assert "give --config, or both --dataset-settings and --method-settings" in capsys.readouterr().err
    assert cli(["descriptors", "--dataset", "d", "--method", "sad", "--dataset-settings", "[1]", "--method-settings",
                METHOD, "--out", str(tmp_path / "sad.h5")]) == 2
    assert "--dataset-settings must be a JSON object, got [1]" in capsys.readouterr().err
    assert cli(["descriptors", "--dataset", "d", "--method", "sad", "--dataset-settings", DATASET, "--method-settings",
                METHOD, "--out", str(tmp_path / "sad.npy")]) == 2
    assert "sad.npy" in capsys.readouterr().err and not list(tmp_path.iterdir())


def test_distances_says_what_it_wrote(tmp_path, caplog):
    import h5py

    with h5py.File(tmp_path / "d.h5", "w") as f:
        f["reference"] = np.eye(6, 4, dtype=np.float32) + 1
        f["query"] = np.eye(6, 4, dtype=np.float32)[::-1] + 1
        f.attrs.update(distance="mad", dataset="toy", method="m", checkpoint_sha256="", frames_sha256="abc")
    out = tmp_path / "val.h5"
    with caplog.at_level(logging.INFO, logger="vpr_smr"):
        assert cli(["distances", "--descriptors", str(tmp_path / "d.h5"), "--split", "val", "--frames", "1", "5",
                    "--out", str(out)]) == 0
    assert [r.getMessage() for r in caplog.records if r.getMessage().startswith("wrote")] == [
        f"wrote the val split's distance matrix to {out}"]
    with h5py.File(out) as f:
        # mean absolute differences by hand: rows 1..4 of eye(6, 4) + 1 against rows 1..4 of its reversed rows
        reference, query = np.eye(6, 4)[1:5], np.eye(6, 4)[::-1][1:5]
        expected = np.abs(reference[:, None, :] - query[None, :, :]).mean(axis=2)
        np.testing.assert_allclose(f["distance_matrix"][()], expected, rtol=1e-6)


def test_the_speed_comes_beside_the_job():
    """The descriptors rule gives its job as a param and its threads, batch size and workers as options beside it
    (a resource: changing them reruns nothing); those given replace the job's, one by one within a group."""
    job = DescriptorsJob("route", "sad", None, DATASET, METHOD, "f" * 64, Extraction(8, None), None, "sad.h5")
    args = build_parser(job=True).parse_args(["descriptors", "--job", job_text(job), "--threads", "2",
                                              "--num-workers", "1"])
    assert job_of(matching.DESCRIPTORS, args) == DescriptorsJob("route", "sad", None, DATASET, METHOD, "f" * 64,
                                                                Extraction(8, 1), 2, "sad.h5")
    # the other settings are the job's alone
    args = build_parser(job=True).parse_args(["descriptors", "--job", job_text(job), "--out", "other.h5"])
    assert job_of(matching.DESCRIPTORS, args) == job
