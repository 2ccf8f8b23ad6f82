"""evaluate_split and evaluate.main: seeds, both recall@1 rules, trust-level AUC, restoration; values by hand."""

import json

import numpy as np
import pytest
from helpers import make_features
from training_sets import evaluate_job

from vpr_smr.eval.matching.attributes import Matching, write_features
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.scoring.evaluate import evaluate_split, main


class TablePredictor:
    """A fixed predictor: query ``n``'s rank-``k`` attributes carry the key ``10 n + k`` in A1, and the
    probabilities of each key are given (class 0 with certainty for keys not given)."""

    classes_ = np.arange(4)

    def __init__(self, table: dict[int, list[float]]) -> None:
        self.table = table

    def predict_proba(self, attributes: np.ndarray) -> np.ndarray:
        return np.array([self.table.get(int(key), [1.0, 0, 0, 0]) for key in attributes[:, 0]])


def keyed_features(**overrides):
    features = make_features([True, False, True, False], [[1, 0], [0, 1], [1, 0], [0, 0]], **overrides)
    features.attributes[:, :, 0] = 10 * np.arange(4)[:, None] + np.arange(2)[None, :]
    return features


# sequence distances .1 .2 .3 .4, correct T F T F; the baseline (standard mode, recall over 4 queries) is
# (.25, 1), (.25, .5), (.5, 2/3), (.5, .5).
BASELINE_CUT_AUC = 0.25 + (0.5 + 2 / 3) / 2 * 0.25  # 19/48
REMOVE_Q1 = {10: [0.2, 0, 0, 0.8]}  # q1 predicted wrong (class 3) with probability .8
REMOVE_Q1_Q3 = {10: [0, 0, 0, 1.0], 30: [0, 0, 0, 1.0]}


def test_seeds_recall_and_trust_levels():
    features = keyed_features(all_single_correct=np.array([False, True, False, True, False]),
                              single_correct=np.array([True, False, True, False]))
    seeds = [TablePredictor(REMOVE_Q1), TablePredictor({}), TablePredictor(REMOVE_Q1_Q3)]
    split = evaluate_split(features, seeds, modes=("standard", "paper"), trust_levels=(0.0, 0.9))[0]
    result = split.to_json()
    standard = result["modes"]["standard"]
    # seed 0 removes q1 (wrong): (.25, 1), (.5, 1), (.5, 2/3) -> AUC .5, R_max .5; AOC .5 - 19/48 -> 0.
    assert standard["reduction"]["auc_vpr_sm_pred"] == pytest.approx(0.5)
    assert standard["reduction"]["aoc_vpr_sm"] == pytest.approx(0.5 - BASELINE_CUT_AUC)
    assert standard["reduction"]["reduction_pct"] == pytest.approx(100.0)
    # recall@1 single: paper mode over the split's 5 queries (2 right), standard over the 4 evaluated (2 right)
    assert result["modes"]["paper"]["recall_at_1_single"] == pytest.approx(0.4)
    assert standard["recall_at_1_single"] == pytest.approx(0.5)
    assert (result["recall_at_1_single_all"], result["recall_at_1_single_evaluated"]) == pytest.approx((0.4, 0.5))
    assert result["n_queries_split"] == 5 and result["n_queries"] == 4
    # seeds: reductions 100 (seed 0), 0 (removes nothing), 100 (removes both wrong matches); seed 0's numbers are
    # the split's own, written once
    assert result["seed"] == 0 and [s["seed"] for s in result["other_seeds"]] == [1, 2]
    assert [s.seed for s in split.seeds] == [0, 1, 2]
    assert [s.modes["standard"].reduction_pct for s in split.seeds] == pytest.approx([100, 0, 100])
    summary = result["seed_summary"]["standard"]
    assert summary["reduction_pct_mean"] == pytest.approx(200 / 3)
    assert summary["reduction_pct_std"] == pytest.approx(np.sqrt((2 * (100 / 3) ** 2 + (200 / 3) ** 2) / 2))
    assert (summary["reduction_pct_min"], summary["reduction_pct_max"], summary["n_seeds"]) == (0, 100, 3)
    # trust .9: q1's prediction (.8) is not trusted, so nothing is removed and the curve is the baseline's
    trust = standard["trust_auc"]
    assert trust["0.0"]["removed"] == 1 and trust["0.9"]["removed"] == 0
    assert trust["0.0"]["auc"] == pytest.approx(0.5)
    assert trust["0.9"]["auc"] == pytest.approx(BASELINE_CUT_AUC) and trust["0.9"]["reduction_pct"] == 0
    assert standard["trust"]["0.9"]["recall"] == pytest.approx([0, 0.25, 0.25, 0.5, 0.5])
    assert result["confusion_matrix"][2][3] == 0 and result["predicted_counts"] == [3, 0, 0, 1]
    assert "restoration" not in result


def test_restoration_is_added_on_request():
    # q1 removed; its rank-1 alternative (key 11) is predicted right and is right
    features = keyed_features()
    predictor = TablePredictor({**REMOVE_Q1, 11: [0.9, 0.1, 0, 0], 1: [1, 0, 0, 0]})
    result = evaluate_split(features, [predictor], modes=("standard",), trust_levels=(), restoration=True)[0].to_json()
    restoration = result["restoration"]
    assert (restoration["removed"], restoration["restored"], restoration["wrong_to_right"]) == (1, 1, 1)
    # restoration keeps every query, q1 now right: T T T F -> (.25,1), (.5,1), (.75,1), (.75,.75): AUC .75
    assert restoration["modes"]["standard"]["auc_restoration"] == pytest.approx(0.75)
    assert "trust" not in result["modes"]["standard"]


def test_main_writes_every_split_and_seed(tmp_path):
    from vpr_smr.eval.matching.attributes import query_features

    rng = np.random.default_rng(0)
    matrix = rng.random((60, 60)) + 0.7 * (1 - np.eye(60))
    features = query_features(matrix, 4)
    write_features(tmp_path / "test.h5", features, {"attributes_seconds": 0.5})
    paths = []
    for seed in (0, 1):
        predictor = SMRPredictor(hidden_layer_sizes=(8,), max_iter=50, random_state=seed)
        predictor.fit(features.attributes[:, 0], features.labels).save(tmp_path / f"p{seed}.h5", Matching())
        paths.append(tmp_path / f"p{seed}.h5")
    main(evaluate_job({"test": tmp_path / "test.h5"}, paths, tmp_path / "e.json", modes=("paper",),
                      trust_levels=(0.0,)))
    result = json.loads((tmp_path / "e.json").read_text())
    split = result["splits"]["test"]
    assert len(split["other_seeds"]) == 1 and not any(key.endswith("seconds") for key in split)
    # timings go beside the results, so that two runs give identical result files
    timing = json.loads((tmp_path / "e.timing.json").read_text())["splits"]["test"]
    assert timing["attributes_seconds"] == 0.5 and timing["n_queries"] == 57
    assert timing["seconds_per_query"] == pytest.approx((0.5 + timing["predict_seconds"]) / 57)
    assert set(split["restoration"]["modes"]) == {"paper"}
    with pytest.raises(FileNotFoundError, match="missing.h5"):
        main(evaluate_job({"test": tmp_path / "test.h5"}, [tmp_path / "missing.h5"], tmp_path / "f.json"))
