"""The stage of the experiment deployment (method §16) on small hand-made splits: its thresholds and realised numbers
against naive loops written here, its sources, its deployment names with two datasets, its notes, and its refusals
of bad inputs (before anything is written); and the configuration's check of ``deployment.calibration``."""

from __future__ import annotations

import textwrap
from dataclasses import replace

import numpy as np
import pytest
from helpers import seqslam, write_distance_matrix
from oracles import naive_empirical, naive_guaranteed

from vpr_smr.core.records import load
from vpr_smr.eval.matching.attributes import read_features
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.scoring.deployment import main
from vpr_smr.eval.scoring.deployment_jobs import DatasetFiles, DeployedMatcher, DeploymentInputs, DeploymentJob
from vpr_smr.eval.scoring.deployment_records import DeploymentResult
from vpr_smr.eval.scoring.scorers import BaselineSettings
from vpr_smr.pipeline.config import ConfigError, load_config

SPLITS = {"d": (("val", 60, 30), ("test", 100, 40)), "e": (("test", 10, 36),)}  # dataset: (split, first frame, n)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Datasets d (val, test) and e (test) in our HDF5 layout, their attributes at L = 3 (tolerance 2)."""
    from vpr_smr.eval.matching.attributes import AttributesJob
    from vpr_smr.eval.matching.attributes import main as attributes_main

    folder = tmp_path_factory.mktemp("deployment")
    rng = np.random.default_rng(23)
    distances: dict[str, dict[str, str]] = {}
    attributes: dict[str, dict[str, str]] = {}
    for dataset, splits in SPLITS.items():
        for split, lo, n in splits:
            d = rng.random((n, n)) + 0.5 * (1 - np.eye(n)) * rng.random((n, n))
            path = folder / f"{dataset}_{split}.h5"
            write_distance_matrix(path, d, {"dataset": dataset, "method": "m", "split": split,
                                            "split_range": [lo, lo + n]})
            out = folder / f"{dataset}_{split}_L3.h5"
            attributes_main(AttributesJob(str(path), 3, out=str(out)))
            distances.setdefault(dataset, {})[split] = str(path)
            attributes.setdefault(dataset, {})[split] = str(out)
    return folder, distances, attributes


def job_of(files, predictor_file, deployments=(("d", "test"),), precisions=(0.9, 0.5), out="r.json"):
    folder, distances, attributes = files
    datasets = {name: DatasetFiles(TruthSource(), dict(found)) for name, found in distances.items()}
    inputs = DeploymentInputs(
        "val", tuple(deployments), datasets,
        (DeployedMatcher("seqslam", seqslam(), attributes, (str(predictor_file), str(predictor_file))),))
    return DeploymentJob("d", "m", 3, inputs, tuple(precisions), 0.1, 10, BaselineSettings(6, 5), False,
                         str(folder / out))


def naive_smallest(p, delta):
    """The fewest calibration queries, all correct, with which the binary search keeps a threshold."""
    m = 1
    while naive_guaranteed(list(range(m)), [True] * m, p, delta) is None:
        m += 1
    return m


def test_distance_rows_equal_a_naive_computation(files, predictor_file):
    job = job_of(files, predictor_file)
    result = main(job)
    assert load(job.out, DeploymentResult) == result
    _, _, attributes = files
    val, test = (read_features(attributes["d"][s]) for s in ("val", "test"))
    c_val, y_val = -val.sequence_distance, val.sequence_correct.astype(bool)
    c_test, y_test = [float(v) for v in -test.sequence_distance], [bool(v) for v in test.sequence_correct]
    assert result.meta["n_calibration"] == {"seqslam": len(c_val)} and result.meta["deployments"] == ["test"]
    for p in (0.9, 0.5):
        t = naive_empirical([float(v) for v in c_val], [bool(v) for v in y_val], p)
        row = next(r for r in result.rows if (r.source, r.rule, r.precision) == ("distance", "empirical", p))
        assert row.calibration.threshold == t and row.deployment == "test" and row.seed is None
        taken = [t is not None and v >= t for v in c_test]
        n = sum(taken)
        right = sum(1 for a, ok in zip(taken, y_test, strict=True) if a and ok)
        assert (row.realised.n_queries, row.realised.accepted, row.realised.wrong) == (len(c_test), n, n - right)
        assert row.realised.precision == (right / n if n else None)
        assert row.realised.recall == right / len(c_test)
        # the ceiling: empirical on the deployment itself
        ceiling = naive_empirical(c_test, y_test, p)
        top = [v >= ceiling for v in c_test] if ceiling is not None else [False] * len(c_test)
        best = sum(1 for a, ok in zip(top, y_test, strict=True) if a and ok)
        assert row.ceiling.recall == best / len(c_test)
        assert row.recall_lost == pytest.approx(best / len(c_test) - right / len(c_test))
        assert row.outcome == ("abstained" if n == 0 else "held" if right / n >= p else "violated")
        # same_fraction accepts ceil(f |D|) of the deployment, f = what empirical accepts on the calibration split
        accepted_val = sum(1 for v in c_val if t is not None and v >= t)
        fraction = next(r for r in result.rows if (r.source, r.rule, r.precision) == ("distance", "same_fraction", p))
        want = -(-accepted_val * len(c_test) // len(c_val))
        cut = sorted(c_test, reverse=True)[want - 1] if want else None
        assert fraction.realised.accepted == (sum(1 for v in c_test if v >= cut) if want else 0)
    # every source but random, the predictor per seed (seed 0 first); 3 rules x 2 targets x 1 deployment each
    keys = list(dict.fromkeys((r.source, r.seed) for r in result.rows))
    assert keys == [("uniqueness", None), ("single_uniqueness", None), ("spread", None), ("distance", None),
                    ("native", None), ("oracle", None), ("predictor", 0), ("predictor", 1)]
    assert len(result.rows) == len(keys) * 3 * 2
    # the oracle's calibrated precision is 1
    oracle = [r for r in result.rows if r.source == "oracle" and r.rule == "empirical"]
    assert oracle and all(r.calibration.wrong == 0 and r.calibration.accepted > 0 for r in oracle)
    # one curve per source (seed 0 of the predictor's), its chosen thresholds those of the rows
    assert [(c.source) for c in result.curves] == [k for k, s in keys if s in (None, 0)]
    curve = next(c for c in result.curves if c.source == "distance")
    assert len(curve.coverage) == len(set(c_val.tolist())) and curve.coverage[-1] == 1.0
    assert {(x.rule, x.precision): x.threshold for x in curve.chosen}[("empirical", 0.9)] == naive_empirical(
        [float(v) for v in c_val], [bool(v) for v in y_val], 0.9)


def test_notes_name_a_calibration_split_too_small(files, predictor_file):
    result = main(job_of(files, predictor_file, precisions=(0.9,), out="n.json"))
    needed = naive_smallest(0.9, 0.1)
    n = result.meta["n_calibration"]["seqslam"]
    assert n < needed
    sources = len([c for c in result.curves])  # one per source (seed 0 of the predictor's)
    assert result.notes == (f"seqslam: guaranteed needs at least {needed} calibration queries for precision 0.9 at "
                            f"risk 0.1 (with distinct confidences); the calibration split val has {n}: it abstains "
                            f"there for {sources} of {sources} sources",)
    assert all(r.outcome == "abstained" and r.calibration.threshold is None for r in result.rows
               if r.rule == "guaranteed")


def test_another_datasets_table_split_is_named_with_its_dataset(files, predictor_file):
    _, _, attributes = files
    result = main(job_of(files, predictor_file, deployments=(("d", "test"), ("e", "test")), precisions=(0.5,),
                         out="two.json"))
    assert result.meta["deployments"] == ["test", "e/test"]
    assert {r.deployment for r in result.rows} == {"test", "e/test"}
    e = read_features(attributes["e"]["test"])
    row = next(r for r in result.rows if (r.source, r.rule, r.deployment) == ("distance", "empirical", "e/test"))
    t = row.calibration.threshold
    taken = -e.sequence_distance >= t
    assert row.realised.accepted == int(taken.sum()) and row.realised.n_queries == len(e.queries)
    assert row.realised.wrong == int((taken & ~e.sequence_correct.astype(bool)).sum())


def test_bad_inputs_are_refused_before_writing(files, predictor_file):
    job = job_of(files, predictor_file, out="bad.json")
    folder, distances, _ = files
    without = replace(job.inputs, datasets={"d": DatasetFiles(TruthSource(), {"val": distances["d"]["val"]})})
    with pytest.raises(ValueError, match=r"datasets.d has no distances of split 'test' \(it has val\)"):
        main(replace(job, inputs=without))
    with pytest.raises(ValueError, match="no \"datasets\" entry for 'e'"):
        main(replace(job, inputs=replace(job.inputs, deployments=(("e", "test"),),
                                          datasets={"d": job.inputs.datasets["d"]})))
    with pytest.raises(ValueError, match="no deployment"):
        main(replace(job, inputs=replace(job.inputs, deployments=())))
    with pytest.raises(ValueError, match="deployment.precisions|--precisions"):
        replace(job, precisions=(1.5,))
    assert not (folder / "bad.json").exists()


def test_the_calibration_split_must_be_an_evaluation_split(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text(textwrap.dedent("""
        run: x
        datasets: {d: {loader: nordland_sample}}
        methods: {m: {backend: sad}}
    """))
    with pytest.raises(ConfigError, match=r"deployment.calibration 'train' is not among eval_splits"):
        load_config(path, {"deployment": {"calibration": "train"}})
    assert load_config(path, {"deployment": {"calibration": "test"}}).calibration_split == "test"
    assert load_config(path).calibration_split == "val"
