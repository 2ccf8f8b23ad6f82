"""configs/paper.yaml on small trees of the three benchmarks: Snakemake's dry run plans 3 datasets x 7 methods."""

import json
import re
import shlex
import subprocess
import sys

import yaml
from benchmark_trees import (
    SAMPLE_NAMES,
    nordland_lists,
    nordland_tree,
    robotcar_list,
    robotcar_tree,
    sfu_tree,
    write_lines,
)
from paper_run import METHODS, OFFICIAL_KEYS, PAPER, shaped_checkpoint

from vpr_smr.eval.matching.matchers import MATCHERS


def test_dry_run_plans_every_job(tmp_path):
    conf = yaml.safe_load(PAPER.read_text())
    names = SAMPLE_NAMES[:24]
    nordland_tree(tmp_path / "nordland", names)
    lists = nordland_lists(tmp_path, names)
    stamps = list(range(1000, 1024))
    robotcar_tree(tmp_path / "robotcar", {"2015-10-29-12-18-17": stamps, "2014-11-21-16-07-03": stamps})
    sfu = sfu_tree(tmp_path / "sfu", {"part_a": 14, "part_b": 10})
    splits = {"train": [0, 8], "val": [8, 16], "test": [16, 24]}
    conf["datasets"]["nordland"].update(root=str(tmp_path / "nordland"), splits=splits, **{
        k: str(v) for k, v in lists.items()})
    conf["datasets"]["robotcar"].update(root=str(tmp_path / "robotcar"), splits=splits,
                                        reference_list=str(robotcar_list(tmp_path / "rain.csv", stamps)),
                                        query_list=str(robotcar_list(tmp_path / "dusk.csv", stamps)))
    conf["datasets"]["sfu_mountain"].update(root=str(tmp_path / "sfu"), splits=splits,
                                            reference_list=str(write_lines(tmp_path / "dry.txt", sfu["dry"])),
                                            query_list=str(write_lines(tmp_path / "dusk.txt", sfu["dusk"])))
    for method, settings in conf["methods"].items():
        if "checkpoint" in settings:
            settings["checkpoint"] = str(shaped_checkpoint(tmp_path / f"{method}.pth", OFFICIAL_KEYS[method]))
    conf["output"] = str(tmp_path / "results")
    # the speed experiment's profiles but 2x, which would leave 4 queries of these 8-frame train splits (refused)
    conf["speed"] = {"profiles": [0.5, 0.75, 1.0, 1.25, 1.5, "varying"]}
    # the matchers experiment's built-in matchers but openseqslam, whose ratio window needs 14 references of a split
    # (the plan refuses these 8-frame splits for it)
    conf["matchers"] = [{"matcher": name} for name in MATCHERS if name != "openseqslam"]
    config = tmp_path / "paper.yaml"
    config.write_text(yaml.safe_dump(conf, sort_keys=False))  # the splits as written: train, val, test
    result = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", str(config), "-n", "-v", "--",
                             "--printshellcmds"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    counts = dict(re.findall(r"^(\w+)\s+(\d+)$", result.stdout, flags=re.MULTILINE))
    # 3 datasets x 7 methods x 3 splits; Table II per dataset; a predictor without each method, tested on it; the
    # standard VPR metrics, the per-query CSV and the match inspector of each method at the table's L; the speed
    # experiment per dataset and profile (6 profiles); the matchers experiment per dataset and method, and each built-in
    # matcher
    # but the run's (seqslam) with its own attributes of every method and split and its own predictor per dataset; the
    # deployment experiment per dataset and method (deployed on the other datasets' test splits too)
    others = len(conf["matchers"]) - 1
    assert counts == {"all": "1", "descriptors": "21", "distances": "63", "attributes": "63", "train": "3",
                      "evaluate": "21", "attribute_ablation": "3", "predictor_without": "21", "held_out": "21",
                      "vpr_metrics": "21", "queries": "21", "inspect": "21", "speed": "18", "report": "1",
                      "baselines": "21", "matchers": "21", "deployment": "21",
                      **({"matcher_attributes": str(63 * others), "matcher_train": str(3 * others)} if others else {}),
                      "total": str(362 + 66 * others)}
    for dataset in ("nordland", "robotcar", "sfu_mountain"):
        for method in METHODS:
            assert f"descriptors/{dataset}/{method}.h5" in result.stdout
    # the report is given the dataset cards in the configuration's order: the splits train, val, test (not sorted)
    (report,) = re.findall(r"^Shell command: (vpr-smr report .*)$", result.stdout, flags=re.MULTILINE)
    words = shlex.split(report)
    cards = json.loads(words[words.index("--job") + 1])["datasets"]  # the report's job record
    assert list(cards) == list(conf["datasets"]) == ["nordland", "robotcar", "sfu_mountain"]
    assert all(list(card["splits"]) == ["train", "val", "test"] for card in cards.values())
