"""No predictor scores frames it was trained on: the pooled one, the per-attribute ones (Table II) and the
leave-one-method-out ones, unless the configuration allows overlapping splits."""

from __future__ import annotations

import json

import numpy as np
import pytest
from training_sets import PARAMS, ablation_job, evaluate_job, held_out_job, method_samples, train_job, without_job
from training_sets import write_samples as write_plain

from vpr_smr.eval.matching.attributes import read_features, write_features
from vpr_smr.eval.predictor import ablation, train
from vpr_smr.eval.predictor.leakage import FrameRange, SplitLeakError, check_disjoint, frame_range, trained_on
from vpr_smr.eval.scoring import evaluate, held_out
from vpr_smr.pipeline.cli import main as cli


def features(tmp_path, method: str, split: str, lo: int, hi: int, seed: int):
    """A features file of one method and split with the provenance the workflow writes (dataset, split, range)."""
    x, y = method_samples(hi - lo, seed)
    plain = write_plain(tmp_path / f"plain_{method}_{split}.h5", x, y)
    path = tmp_path / f"{method}_{split}.h5"
    write_features(path, read_features(plain), {"dataset": "d", "method": method, "split": split,
                                                "split_range": [lo, hi]})
    return path


SPLITS = {"train": (0, 60), "val": (60, 90), "test": (90, 130), "leaky_test": (40, 130)}


@pytest.fixture
def files(tmp_path):
    return {(m, s): features(tmp_path, m, s, *r, seed=i + 7 * j)
            for j, m in enumerate(("a", "b")) for i, (s, r) in enumerate(SPLITS.items())}


def test_frame_ranges_by_hand():
    train, test = FrameRange("d", "train", 0, 60), FrameRange("d", "test", 40, 130)
    assert train.shared(test) == (40, 60) and train.shared(FrameRange("d", "val", 60, 90)) is None
    assert train.shared(FrameRange("other", "test", 0, 60)) is None  # another dataset's frames
    with pytest.raises(SplitLeakError, match=r"trained on 'd' split 'train' \[0, 60\), which shares frames "
                                             r"\[40, 60\) with 'd' split 'test' \[40, 130\)"):
        check_disjoint([train], [test], False, "the predictor")
    assert check_disjoint([train], [test], True, "p") == [
        "p was trained on 'd' split 'train' [0, 60), which shares frames [40, 60) with 'd' split 'test' [40, 130)"]


def test_pooled_predictor(files, tmp_path):
    out = tmp_path / "L4.h5"
    train_files = [files["a", "train"], files["b", "train"]]
    with pytest.raises(SplitLeakError, match="split 'leaky_test' \\[40, 130\\)"):
        train.main(train_job(train_files, out, PARAMS, evaluate={"test": [files["a", "leaky_test"]]}))
    assert not out.exists()
    train.main(train_job(train_files, out, PARAMS, evaluate={"val": [files["a", "val"]], "test": [files["a", "test"]]},
                         seeds=2))
    for path in (out, tmp_path / "L4.seed1.h5"):
        assert trained_on(path) == [FrameRange("d", "train", 0, 60)]
    result = tmp_path / "eval.json"
    with pytest.raises(SplitLeakError, match="was trained on 'd' split 'train'"):
        evaluate.main(evaluate_job({"test": files["a", "leaky_test"]}, [out], result, modes=("standard",),
                                   trust_levels=()))
    assert not result.exists()
    evaluate.main(evaluate_job({"val": files["a", "val"], "test": files["a", "test"]}, [out, tmp_path / "L4.seed1.h5"],
                               result, modes=("standard",), trust_levels=()))
    assert set(json.loads(result.read_text())["splits"]) == {"val", "test"}
    # allowed explicitly: it runs
    evaluate.main(evaluate_job({"test": files["a", "leaky_test"]}, [out], result, modes=("standard",), trust_levels=(),
                               allow_split_overlap=True))


def test_per_attribute_predictors(files, tmp_path):
    out = tmp_path / "table2.json"
    with pytest.raises(SplitLeakError, match="the per-attribute predictors was trained on"):
        ablation.attributes_main(ablation_job([files["a", "train"], files["b", "train"]], out, PARAMS,
                                              evaluate={"test": [files["a", "leaky_test"], files["b", "leaky_test"]]}))
    assert not out.exists()
    ablation.attributes_main(ablation_job([files["a", "train"], files["b", "train"]], out, PARAMS,
                                          evaluate={"test": [files["a", "test"], files["b", "test"]]}))
    assert out.is_file()


def test_leave_one_method_out_predictors(files, tmp_path):
    without = tmp_path / "without_b.h5"
    with pytest.raises(SplitLeakError):
        ablation.train_without(without_job({"a": files["a", "train"]}, "b", without, PARAMS,
                                           evaluate={"val": {"a": files["a", "leaky_test"]}}))
    ablation.train_without(without_job({"a": files["a", "train"], "b": files["b", "train"]}, "b", without, PARAMS))
    assert trained_on(without) == [FrameRange("d", "train", 0, 60)]
    pooled = tmp_path / "L4.h5"
    train.main(train_job([files["a", "train"], files["b", "train"]], pooled, PARAMS))
    out = tmp_path / "held_out.json"
    with pytest.raises(SplitLeakError, match="L4.h5 was trained on"):
        held_out.main(held_out_job(files["b", "leaky_test"], pooled, without, out, ("standard",)))
    # each of the two predictors is checked: a pooled one with no recorded ranges leaves the without_ one
    x, y = method_samples(60, 3)
    unrecorded = tmp_path / "unrecorded.h5"
    train.main(train_job([write_plain(tmp_path / "plain.h5", x, y)], unrecorded, PARAMS))
    assert trained_on(unrecorded) == []
    with pytest.raises(SplitLeakError, match="without_b.h5 was trained on"):
        held_out.main(held_out_job(files["b", "leaky_test"], unrecorded, without, out, ("standard",)))
    assert not out.exists()
    held_out.main(held_out_job(files["b", "test"], pooled, without, out, ("standard",)))
    assert json.loads(out.read_text())["n_queries"] == 40


def test_the_command_names_the_setting(files, tmp_path, capsys):
    out = tmp_path / "L4.h5"
    status = cli(["train", "--dataset", "d", "--seq-len", "4", "--predictor", json.dumps(PARAMS),
                  "--train", str(files["a", "train"]), "--evaluate", "test", str(files["a", "leaky_test"]), "--out",
                  str(out)])
    assert status == 2 and "--allow-split-overlap" in capsys.readouterr().err and not out.exists()
    assert cli(["train", "--dataset", "d", "--seq-len", "4", "--predictor", json.dumps(PARAMS), "--train",
                str(files["a", "train"]), "--evaluate", "test", str(files["a", "leaky_test"]), "--out", str(out),
                "--allow-split-overlap"]) == 0


def test_a_users_features_without_provenance_have_no_range(tmp_path):
    x, y = method_samples(20, 0)
    assert frame_range(write_plain(tmp_path / "f.h5", x, y)) is None
    assert np.isfinite(x).all()
