"""A matcher that is only a plugin runs the whole demo workflow: the test package ``toy`` (tests/plugins), seen
through PYTHONPATH alone, named in the demo's configuration as ``sequence_matching: {matcher: toy, ...}``. Every
job, the report included, runs with no edit to vpr_smr; every attributes and predictor file records the matcher
and its settings, and the report names it. The experiment matchers compares it with seqslam, which gets attributes
and predictors of its own while the plugin's are the run's.

Needs issue 34's seam (``sequence_matching.matcher`` in the configuration, ``--matcher`` through the stages): where
the configuration still refuses the key ``matcher``, the test is an expected failure saying so (strict: once the
seam is merged it must pass)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from run_configs import FRAMES, RANGES
from toy_plugin import plugin_env, toy_rule

from vpr_smr.core.io import read_provenance
from vpr_smr.core.records import load
from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.eval.scoring.matcher_comparison import MatcherComparison

DEMO = Path(__file__).resolve().parents[2] / "configs" / "demo.yaml"
MATCHER = {"name": "toy", "settings": {"decay": 0.25, "step": 1}}


pytestmark = pytest.mark.slow


def plugin_config(out: Path) -> dict:
    """configs/demo.yaml on 240 frames of the sample with L 3 and 4, two seeds, SAD and HOG (not the network), one
    speed profile, and the toy matcher, compared with seqslam: every experiment of the demo stays on."""
    conf = yaml.safe_load(DEMO.read_text())
    sample = conf["datasets"]["nordland_sample"]
    sample.update(root=str(DEFAULT_ROOT), frames=list(FRAMES), splits=RANGES)
    conf.update(run="plugin", output=str(out), seq_lens=[3, 4], table_seq_len=4, seeds=2,
                methods={name: conf["methods"][name] for name in ("sad", "hog")},
                predictor={"max_iter": 200}, speed={"profiles": [2.0]},
                sequence_matching={"matcher": MATCHER["name"], **MATCHER["settings"]},
                matchers=[{"matcher": MATCHER["name"], **MATCHER["settings"]}, {"matcher": "seqslam"}])
    return conf


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plugin_matcher")
    config = tmp / "plugin.yaml"
    config.write_text(yaml.safe_dump(plugin_config(tmp / "results"), sort_keys=False))
    result = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", str(config), "--cores", "2"],
                            cwd=tmp, env=plugin_env(), capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return tmp / "results" / "plugin"


def test_every_attributes_and_predictor_file_records_the_plugin(run):
    attributes = sorted(run.glob("attributes/**/*.h5"))
    expected = {run / f"attributes/nordland_sample/{m}/L{n}/{s}.h5" for m in ("sad", "hog") for n in (3, 4)
                for s in RANGES}
    assert expected <= set(attributes)
    predictors = sorted(run.glob("predictors/**/*.h5"))
    assert run / "predictors/nordland_sample/L4.h5" in predictors
    for path in attributes + predictors:
        assert read_provenance(path).get("matcher") == MATCHER, path


def test_the_sequence_matches_are_the_plugins(run):
    """Each split's sequence matches, as its attributes file keeps them, are the toy rule's on the split's distance
    matrix, worked out here with loops (the filter starts at the split's first query)."""
    for method in ("sad", "hog"):
        for split in RANGES:
            with h5py.File(run / f"distances/nordland_sample/{method}/{split}.h5") as f:
                matrix = f["distance_matrix"][()]
            _, matches, _ = toy_rule(matrix, MATCHER["settings"]["decay"], MATCHER["settings"]["step"])
            with h5py.File(run / f"attributes/nordland_sample/{method}/L4/{split}.h5") as f:
                queries, found = f["queries"][()], f["sequence_match"][()]
            assert len(queries) >= matrix.shape[1] - 3, (method, split)  # at least the queries L = 4 evaluates
            np.testing.assert_array_equal(found, np.asarray(matches)[queries], err_msg=f"{method} {split}")


def test_the_report_names_the_plugin(run):
    """Outside its copy of the configuration (which names it in any case) and its inlined figures."""
    text, copies = re.subn(r'<section id="configuration">.*?</section>', "", (run / "report.html").read_text(),
                           flags=re.S)
    assert copies == 1
    text = re.sub(r"data:[^\"')\s]+", "", text)  # the figures inlined as base64, where any word may turn up
    assert re.search(r"\btoy\b", text)
    assert '<p class="subtitle">' in text and "sequence matcher toy (decay 0.25, step 1)" in text


def test_the_matchers_experiment_compares_the_plugin_with_seqslam(run):
    """The plugin (the run's matcher) reuses the run's files; seqslam gets its own attributes and predictors (two
    seeds, at both lengths: the experiment adaptive_seq_len runs it at L = 3 too); both are scored on the test
    split's queries 3..69 (each evaluates every query with a window of 4)."""
    first = load(run / "matchers/nordland_sample/sad/L4.json", MatcherComparison)
    toy = first.tags[0]  # the configuration's order
    assert toy.startswith("toy-") and first.meta["matchers"][toy] == MATCHER  # decay 0.25 is not its default
    assert not (run / "matchers/nordland_sample" / toy).exists()
    own = run / "matchers/nordland_sample/seqslam"
    assert sorted(p.name for p in (own / "predictors").glob("*.h5")) == ["L3.h5", "L3.seed1.h5", "L4.h5",
                                                                          "L4.seed1.h5"]
    for method in ("sad", "hog"):
        result = load(run / f"matchers/nordland_sample/{method}/L4.json", MatcherComparison)
        assert result.tags == (toy, "seqslam") and set(result.matchers) == {toy, "seqslam"}
        assert result.n_queries == 70 - 3 and result.n_queries_validation == 70 - 3
        for split in RANGES:
            path = own / f"attributes/{method}/L4/{split}.h5"
            assert read_provenance(path)["matcher"] == {"name": "seqslam", "settings": {"velocities": [1.0]}}
        # sequence recall@1, read back from each matcher's own test attributes (every query there is shared)
        for tag, path in ((toy, run / f"attributes/nordland_sample/{method}/L4/test.h5"),
                          ("seqslam", own / f"attributes/{method}/L4/test.h5")):
            with h5py.File(path) as f:
                recall = float(np.mean(f["sequence_correct"][()]))
            assert result.matchers[tag][method].modes["paper"].recall_at_1_sequence == recall, (tag, method)
    page = (run / "report.html").read_text()
    assert '<section id="matchers">' in page and "SMR reduces the AOC for " in page
    assert (run / "figures/matchers_nordland_sample_L4_paper.png").is_file()


def test_the_adaptive_sequence_length_runs_the_plugin_too(run):
    """With L 3 and 4 the experiment adaptive_seq_len runs for the run's matcher (the plugin, its files) and for each
    compared matcher (seqslam), each on the test split's queries 3..69, the live matcher on the plugin's frames too."""
    from vpr_smr.eval.scoring.adaptive_records import AdaptiveResult, AdaptiveTiming

    toy = load(run / "matchers/nordland_sample/sad/L4.json", MatcherComparison).tags[0]
    for tag in (toy, "seqslam"):
        for method in ("sad", "hog"):
            result = load(run / f"adaptive/nordland_sample/{tag}/{method}.json", AdaptiveResult)
            assert result.meta["tag"] == tag and result.lengths == (3, 4) and result.n_queries == 70 - 3
            timing = load(run / f"adaptive/nordland_sample/{tag}/{method}.timing.json", AdaptiveTiming)
            assert timing.refused is None and timing.n_queries == 70 - 3
    assert load(run / f"adaptive/nordland_sample/{toy}/sad.json", AdaptiveResult).meta["matcher"] == MATCHER
