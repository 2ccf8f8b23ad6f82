"""docs/extending.md's recipes, run as written: each section's Python blocks (named by their first line) and its
``pyproject.toml`` lines, which register the plugins through a dist-info as ``pip install`` would. What each one
computes is checked against values worked out by hand."""

from __future__ import annotations

import csv
import importlib
import re
import sys
import tomllib
from pathlib import Path

import cv2
import numpy as np
import pytest
from helpers import make_features
from report_runs import build_run

from vpr_smr.datasets import DatasetError, load_dataset, loader, loader_options, required_options
from vpr_smr.descriptors import available_backends, backend_class
from vpr_smr.eval.matching.matchers import MatcherSpec, available_matchers, matcher_class
from vpr_smr.eval.report import registry  # at collection: its tables are the package's, before a recipe's plugin
from vpr_smr.eval.scoring import scorers

DOC = Path(__file__).resolve().parents[2] / "docs" / "extending.md"
BLOCK = re.compile(r"^```(\w+)\n(.*?)^```", re.S | re.M)


def sections() -> dict[str, list[tuple[str, str]]]:
    """Each ``## `` section's code blocks: (language, text)."""
    parts = re.split(r"^## (.+)$", DOC.read_text(), flags=re.M)
    return {title: BLOCK.findall(body) for title, body in zip(parts[1::2], parts[2::2], strict=True)}


def python(section: str) -> dict[str, str]:
    """The Python blocks of ``section`` by their first line (``# my_vpr/backend.py``), that line included."""
    found = {}
    for language, text in sections()[section]:
        if language == "python":
            found[text.splitlines()[0].removeprefix("# ")] = text
    return found


@pytest.fixture
def my_vpr(tmp_path, monkeypatch):
    """The recipes' package ``my_vpr`` installed under ``tmp_path``: its modules from the blocks named
    ``my_vpr/...``, a dist-info with the entry points of every ``toml`` block, the folder on sys.path."""
    package = tmp_path / "my_vpr"
    package.mkdir()
    (package / "__init__.py").write_text("")
    entry_points = []
    for blocks in sections().values():
        for language, text in blocks:
            name = text.splitlines()[0].removeprefix("# ")
            if language == "python" and name.startswith("my_vpr/"):
                (tmp_path / name).write_text(text)
            if language == "toml":
                for key, points in tomllib.loads(text)["project"]["entry-points"].items():
                    entry_points += [f"[{key}]", *(f"{n} = {target}" for n, target in points.items())]
    info = tmp_path / "my_vpr-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-vpr\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("\n".join(entry_points) + "\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    for module in [m for m in sys.modules if m == "my_vpr" or m.startswith("my_vpr.")]:
        del sys.modules[module]


def test_the_recipes_are_the_six_named():
    assert list(sections()) == ["A descriptor backend", "A dataset loader", "A sequence matcher",
                                "A training-free scorer", "A table", "An experiment"]
    assert "docs/extending.md" in (DOC.parents[1] / "README.md").read_text()


def test_the_backend_recipe(my_vpr):
    module = importlib.import_module("my_vpr.backend")
    assert "cell_colour" in available_backends()
    assert backend_class("cell_colour") is module.CellColour
    assert backend_class("my_vpr.backend:CellColour") is module.CellColour
    assert module.CellColour.default_conf == {"grid": 2}  # from its Settings record
    assert module.CellColour.settings_help == {"grid": "the number of cells per side: grid x grid cells, 3 values each"}
    image = np.zeros((5, 4, 3), np.uint8)  # 5 rows: the last one drops out of a 2 x 2 grid
    image[:, :2] = (10, 20, 30)
    image[:, 2:] = (50, 60, 70)
    image[2:4, :2] = (110, 120, 130)
    image[4] = 255
    descriptor = backend_class("cell_colour")({}).describe(image)
    cells = [10, 20, 30, 50, 60, 70, 110, 120, 130, 50, 60, 70]  # top left, top right, bottom left, bottom right
    np.testing.assert_allclose(descriptor, np.array(cells, np.float32) / 255, rtol=1e-6)
    assert descriptor.dtype == np.float32
    assert backend_class("cell_colour")({"grid": 1}).describe(image[:4]).tolist() == pytest.approx(
        [(10 + 110 + 2 * 50) / 4 / 255, (20 + 120 + 2 * 60) / 4 / 255, (30 + 130 + 2 * 70) / 4 / 255])
    with pytest.raises(ValueError, match="backend 'cell_colour' has no setting grids; its settings are grid"):
        backend_class("cell_colour")({"grids": 3})


def _frames(folder: Path, n: int) -> None:
    folder.mkdir(parents=True)
    for i in range(n):
        cv2.imwrite(str(folder / f"f{i + 1}.png"), np.full((8, 8, 3), 20 * i, np.uint8))


def test_the_dataset_loader_recipe(my_vpr, tmp_path, capsys):
    assert loader("my_route") is importlib.import_module("my_vpr.route").MY_ROUTE
    assert loader_options("my_route") == ["root"] == required_options("my_route")  # splits, tolerance: every loader's
    root = tmp_path / "route"
    _frames(root / "day", 12)
    _frames(root / "night", 12)
    pair = load_dataset("route", {"loader": "my_route", "root": str(root), "splits": {"a": [0, 8], "b": [8, 12]}})
    assert pair.name == "route" and len(pair) == 12 and pair.tolerance == 2
    # natural order: f2 before f10
    assert [p.name for p in pair.query.images[:3]] == ["f1.png", "f2.png", "f3.png"]
    assert pair.reference.images[9] == root / "day" / "f10.png"
    assert pair.splits == {"a": (0, 8), "b": (8, 12)}
    with pytest.raises(DatasetError, match=r"split 'train' = \[0, 500\) is outside the 12 frames"):  # its SPLITS
        load_dataset("route", {"loader": "my_route", "root": str(root)})
    with pytest.raises(DatasetError, match=r"root folder .*nowhere does not exist; set the dataset's root to"):
        load_dataset("route", {"loader": "my_route", "root": str(tmp_path / "nowhere")})
    with pytest.raises(DatasetError, match=r"datasets\.route\.tolerence: .*did you mean 'tolerance'"):
        load_dataset("route", {"loader": "my_route", "root": str(root), "tolerence": 1})
    (root / "night" / "f12.png").unlink()
    with pytest.raises(DatasetError, match="has 12 frames but the query traverse .* has 11"):
        load_dataset("route", {"loader": "my_route", "root": str(root)})
    from vpr_smr.datasets import check

    (root / "day" / "f12.png").unlink()
    assert check.main({"loader": "my_route", "root": str(root), "splits": {"all": [0, 11]}}, "route", decode=False,
                      workers=1) == 0
    out = capsys.readouterr().out
    assert "dataset 'route': 11 aligned frames, tolerance 2" in out and "paired by name order" in out
    assert "10  f11.png  <->  f11.png" in out and "status: OK" in out


def test_the_matcher_recipe(my_vpr):
    module = importlib.import_module("my_vpr.matcher")
    assert "diagonal_quantile" in available_matchers()
    assert matcher_class("diagonal_quantile") is module.DiagonalQuantile
    spec = MatcherSpec.of("diagonal_quantile", {"quantile": 0.25})
    assert spec.provenance() == {"name": "diagonal_quantile", "settings": {"quantile": 0.25}}
    with pytest.raises(ValueError, match=r"sequence_matching\.quantile: .*must be <= 1, got 1\.5"):
        MatcherSpec.of("diagonal_quantile", {"quantile": 1.5})

    d = np.array([[1.0, 9.0, 4.0, 0.0],
                  [5.0, 2.0, 7.0, 3.0],
                  [6.0, 8.0, 0.0, 1.0],
                  [2.0, 4.0, 6.0, 5.0]])
    matcher = MatcherSpec.of("diagonal_quantile").build(3)
    matcher.check(d.shape)
    assert matcher.evaluated(4) == (2, 4)
    block, state = matcher.block(d.T, 0, matcher.initial_state())
    # query 2: the diagonal ending at r = 2 reads D[0,0], D[1,1], D[2,2] = 1, 2, 0 (median 1); at r = 3 D[1,0],
    # D[2,1], D[3,2] = 5, 8, 6 (6). Query 3: at r = 2 D[0,1], D[1,2], D[2,3] = 9, 7, 1 (7); at r = 3 2, 0, 5 (2)
    inf = np.inf
    np.testing.assert_array_equal(block.queries, [2, 3])
    np.testing.assert_array_equal(block.scores, [[inf, inf, 1, 6], [inf, inf, 7, 2]])
    np.testing.assert_array_equal(block.match, [2, 3])
    assert block.native is None and matcher.native_scorer == "uniqueness" and state is None
    lowest = MatcherSpec.of("diagonal_quantile", {"quantile": 0.0}).build(3).block(d.T, 0, None)[0]
    np.testing.assert_array_equal(lowest.scores[:, 2:], [[0, 5], [1, 0]])  # the smallest along each diagonal
    with pytest.raises(ValueError, match=r"D has shape \(2, 4\); diagonal_quantile needs at least L = 3"):
        matcher.check((2, 4), "D")

    # blocks that hold the columns their queries read (L - 1 columns before the first) give the whole split's
    big = np.random.default_rng(3).random((15, 20))
    whole = matcher.block(big.T, 0, None)[0]
    parts = [matcher.block(big[:, lo:hi].T, lo, None)[0] for lo, hi in ((0, 7), (5, 13), (11, 20))]
    np.testing.assert_array_equal(np.concatenate([p.queries for p in parts]), np.arange(2, 20))
    np.testing.assert_array_equal(np.concatenate([p.scores for p in parts]), whole.scores)
    np.testing.assert_array_equal(np.concatenate([p.match for p in parts]), whole.match)


def test_the_scorer_recipe(my_vpr):
    entry = importlib.import_module("my_vpr.scorer").MARGIN
    assert scorers.scorer("margin") is entry and (entry.kind, entry.settings) == ("training-free", ())
    assert scorers.training_free() == ("uniqueness", "single_uniqueness", "spread", "distance", "native", "margin",
                                       "random")
    assert scorers.colour("margin") == "tab:red"
    assert len({s.colour for s in scorers.entries()}) == len(scorers.entries()) == 9
    candidates = np.array([[0.5, 0.75, 2.0], [1.0, 1.0, 3.0], [0.25, 2.0, np.inf]])
    features = make_features([True, False, True], np.ones((3, 2), bool), sequence_candidates=candidates,
                             sequence_distance=np.array([0.5, 1.0, 0.25]))
    confidence = scorers.scorer("margin").confidence
    assert confidence is not None
    values = confidence(features, scorers.DEFAULT_SETTINGS, np.arange(10.0), 0)
    np.testing.assert_array_equal(values, [0.25, 0.0, 1.75])


@pytest.fixture
def recall_gain(tmp_path, monkeypatch):
    """The table recipe's module in a folder added to ``eval/report/tables``' path, collected as the registry
    collects the package's own modules."""
    from vpr_smr.eval.report import registry, tables

    folder = tmp_path / "more_tables"
    folder.mkdir()
    (folder / "recall_gain.py").write_text(python("A table")["eval/report/tables/recall_gain.py"])
    monkeypatch.setattr(tables, "__path__", [*tables.__path__, str(folder)])
    monkeypatch.setattr(registry, "TABLES", registry.collected(*registry.CORE_TABLES, *registry.declared()))
    yield registry
    sys.modules.pop("vpr_smr.eval.report.tables.recall_gain", None)


def test_the_table_recipe(recall_gain, tmp_path):
    registry = recall_gain
    assert registry.TABLES[-1].name == "recall_gain"
    assert "tables/recall_gain.csv" in registry.expected_outputs(["d"], [4], ["paper"], {"metrics"})
    assert "tables/recall_gain.csv" not in registry.expected_outputs(["d"], [4], ["paper"], {"table1"})
    run, written = build_run(tmp_path, modes=("paper", "standard"), seq_lens=(4,), baselines=False, inspector=False)
    assert {run / "tables" / f"recall_gain{suffix}" for suffix in (".csv", ".md", ".tex")} <= set(written)
    with open(run / "tables" / "recall_gain.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    # report_runs.metrics_record: recall@1 = base + 0.05 (mode: paper 0, standard 1) + 0.1 (single 0, sequence 1),
    # base 0.1 + 0.3 (sum of the name's code points mod 3): m1 (158) 0.7, m2 (159) 0.1
    assert [(r["dataset"], r["method"], r["seq_len"], r["mode"], r["n_queries"]) for r in rows] == [
        ("d", "m1", "4", "paper", "57"), ("d", "m1", "4", "standard", "57"), ("d", "m2", "4", "paper", "57"),
        ("d", "m2", "4", "standard", "57")]  # 60 queries, the first L - 1 = 3 without a sequence
    assert [float(r["gain_pct"]) for r in rows] == pytest.approx([100 * 0.1 / 0.7, 100 * 0.1 / 0.75, 100.0,
                                                                 100 * 0.1 / 0.15])
    assert all(r["correct_matches"] == "within 2 frames" for r in rows)
    page = (run / "report.html").read_text()
    section = page.split('<section id="recall-gain">')[1].split("</section>")[0]
    # the whole table folded under the intro, headed by the CSV's names, its numbers as the column's format says
    assert "<h2>Recall gained by sequence matching</h2>" in section and "the whole table, 4 rows" in section
    assert "gain_<wbr>pct" in section and 'data-sort="100.0">100.0<' in section and ">14.3<" in section
    markdown = (run / "tables" / "recall_gain.md").read_text().splitlines()
    assert markdown[-1] == "| d | m2 | 4 | standard | 57 | 66.6667 |"  # 100 * (0.25 / 0.15 - 1), 4 decimals


def test_the_experiment_recipe(my_vpr, tmp_path, monkeypatch):
    """The recipe's experiment ``fixes``, registered by its entry point: the configuration turns it on by name, its
    job counts the fixed and broken queries of a hand-made attributes file, and the report writes its table from the
    jobs' files and shows its section."""
    import h5py
    import yaml

    from vpr_smr.eval.report import build
    from vpr_smr.eval.report.experiments import files as experiments_files
    from vpr_smr.pipeline.config import ConfigError, experiments, validate
    from vpr_smr.pipeline.experiment import experiment, plugin_experiments

    declared = experiment("fixes")
    assert declared is importlib.import_module("my_vpr.experiment").EXPERIMENT
    assert "fixes" in [one.name for one in plugin_experiments()]
    demo = yaml.safe_load((DOC.parents[1] / "configs" / "demo.yaml").read_text())
    assert "fixes" in experiments(validate({**demo, "experiments": {"fixes": True}}))
    assert "fixes" not in experiments(validate(demo))
    with pytest.raises(ConfigError, match=r"experiments.fixs: unexpected key 'fixs' \(did you mean 'fixes'\?\)"):
        validate({**demo, "experiments": {"fixs": True}})
    # the job: of 5 evaluated queries, query 1 and 4 made right (2 / 5), query 3 made wrong (1 / 5)
    attributes = tmp_path / "test.h5"
    with h5py.File(attributes, "w") as f:
        f["single_correct"] = np.array([1, 0, 0, 1, 0], dtype=bool)
        f["sequence_correct"] = np.array([1, 1, 0, 0, 1], dtype=bool)
        f.attrs["seq_len"] = 4
    settings = {"datasets": {"d": {}}, "methods": {"m1": {}, "m2": {}}, "seq_lens": [2, 4], "table_seq_len": 4,
                "experiments": {"fixes": True}}
    assert declared.outputs(settings) == ["fixes/d/m1/L4.json", "fixes/d/m2/L4.json"]
    run = tmp_path / "run"  # report_runs.build_run's run folder: the jobs write into it
    stage = declared.jobs[0].stage
    found = stage(attributes=str(attributes), dataset="d", method="m1", out=str(run / "fixes/d/m1/L4.json"))
    assert (found["n_queries"], found["fixed"], found["broken"]) == (5, 0.4, 0.2)
    stage(attributes=str(attributes), dataset="d", method="m2", out=str(run / "fixes/d/m2/L4.json"))
    # the report: the registry collects the installed experiments' tables when it is imported (here before the
    # recipe's package was installed), so this process adds them as a new one would
    assert "fixes" not in [entry.name for entry in registry.TABLES]
    monkeypatch.setattr(registry, "TABLES", registry.collected(*registry.TABLES, *registry.plugin_tables()))
    assert "tables/fixes.csv" in registry.expected_outputs(["d"], [4], ["paper"], {"table1", "fixes"})
    # the files of the experiments the run's settings turn on, where its jobs wrote them (build_run's report shows
    # settings of its own, without ``experiments``)
    assert experiments_files(run, settings) == {"fixes": [run / "fixes/d/m1/L4.json", run / "fixes/d/m2/L4.json"]}
    monkeypatch.setattr(build, "experiment_files", lambda out_dir, config: experiments_files(out_dir, settings))
    _, written = build_run(tmp_path, seq_lens=(4,), baselines=False, inspector=False)
    assert run / "tables" / "fixes.csv" in written
    with open(run / "tables" / "fixes.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["method"], r["n_queries"], r["fixed"], r["broken"]) for r in rows] == [
        ("m1", "5", "0.4", "0.2"), ("m2", "5", "0.4", "0.2")]
    section = (run / "report.html").read_text().split('<section id="fixes">')[1].split("</section>")[0]
    assert "<h2>Fixed and broken matches</h2>" in section
    assert "The share of queries whose match sequence matching makes right, and wrong." in section
