"""A matcher's bad settings and the splits it cannot match are said before any job runs (method §14): the
workflow's plan asks ``Matcher.check`` on each split's own shape (references x queries), and every stage command
takes the chosen matcher's settings as options generated from its settings record (the plugin ``toy``)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from types import SimpleNamespace

import pytest
from toy_plugin import PLUGIN_SITE

from vpr_smr.core.settings import setting
from vpr_smr.eval.matching.matchers import ENTRY_POINT_GROUP, MatcherSpec
from vpr_smr.eval.matching.matchers.base import Matcher
from vpr_smr.pipeline.cli import build_parser
from vpr_smr.pipeline.config import ConfigError, validate
from vpr_smr.pipeline.options import matcher_of, read_matcher
from vpr_smr.pipeline.plan import preflight

# each stage command's required words, the matcher's options added after them
REQUIRED = {
    "attributes": ["--distances", "D.npy", "--seq-len", "4", "--out", "a.h5"],
    "metrics": ["--distances", "D.npy", "--seq-len", "4", "--out", "m.json"],
    "queries": ["--distances", "D.npy", "--seq-len", "4", "--out", "q.csv"],
    "baselines": ["--dataset", "d", "--method", "m", "--seq-len", "4", "--distances", "test=D.npy", "--attributes",
                  "test=a.h5", "--predictors", "p.h5", "--out", "b.json"],
    "inspect": ["--queries", "q.csv", "--distances", "D.npy", "--matrix-figure", "f.png", "--seq-len", "4"],
}


@pytest.fixture
def toy(monkeypatch):
    monkeypatch.syspath_prepend(str(PLUGIN_SITE))


@pytest.mark.parametrize("command", REQUIRED)
def test_every_stage_takes_a_plugin_matchers_own_options(toy, command):
    argv = [command, *REQUIRED[command], "--matcher", "toy", "--decay", "0.25", "--step", "2"]
    assert matcher_of(argv) == "toy"
    args = build_parser(matcher_of(argv)).parse_args(argv)
    assert read_matcher(args) == MatcherSpec.of("toy", {"decay": 0.25, "step": 2})
    default = build_parser("toy").parse_args([command, *REQUIRED[command], "--matcher", "toy"])
    assert read_matcher(default).values == {"decay": 0.5, "step": 1}  # its declared defaults
    bad = build_parser("toy").parse_args([command, *REQUIRED[command], "--matcher", "toy", "--decay", "2"])
    with pytest.raises(ValueError, match=re.escape("--decay: weight of the previous query's score carried along the "
                                                   "diagonal; must be <= 1, got 2.0")):
        read_matcher(bad)
    with pytest.raises(SystemExit):  # seqslam's option is not the toy's
        build_parser("toy").parse_args([command, *REQUIRED[command], "--matcher", "toy", "--velocities", "1"])
    seqslam = build_parser().parse_args([command, *REQUIRED[command], "--velocities", "2", "1"])
    assert read_matcher(seqslam) == MatcherSpec.of("seqslam", {"velocities": [1.0, 2.0]})


@pytest.mark.parametrize("settings", [{"decay": -0.5}, {"step": 0.5}, {"decya": 1}])
def test_a_bad_setting_stops_the_configuration(toy, tmp_path, settings):
    with pytest.raises(ConfigError, match=r"sequence_matching\.(decay|step|decya)"):
        validate(_config(tmp_path, {"matcher": "toy", **settings}))


@pytest.fixture
def centred(monkeypatch):
    """``centred`` registered as an installed package's entry point would register it."""

    point = SimpleNamespace(name="centred", load=lambda: Centred)
    monkeypatch.setattr("vpr_smr.core.registry.entry_points",
                        lambda group: [point] if group == ENTRY_POINT_GROUP else [])


@dataclass(frozen=True)
class _Settings:
    extra: int = setting(2, "queries read after the query", minimum=0)


class Centred(Matcher):
    """Needs ``L + extra`` queries (a centred window reads ``extra`` columns after its query); matched nowhere here."""

    name = "centred"
    Settings = _Settings
    description = "a test's matcher that reads columns after its query"
    native_scorer = "uniqueness"

    @property
    def lookback(self) -> int:
        return self.seq_len - 1

    @property
    def lookahead(self) -> int:
        return int(self.settings.extra)

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        need = self.seq_len + self.lookahead
        if shape[1] < need:
            raise ValueError(f"{name} has {shape[1]} queries; this matcher needs {need}")

    def block(self, columns, first_column, state):  # type: ignore[no-untyped-def]
        raise AssertionError("not run: the plan stops first")


def _config(tmp_path, matching, splits=None) -> dict:
    return {"run": "r", "output": str(tmp_path / "out"), "seq_lens": [3, 5],
            "datasets": {"sample": {"loader": "nordland_sample", "frames": [1000, 1100],
                                    "splits": splits or {"train": [0, 40], "val": [40, 46], "test": [60, 100]}}},
            "methods": {"sad": {"backend": "sad"}}, "sequence_matching": matching,
            "experiments": {"speed": False, "matchers": False}}


def test_the_plan_checks_each_split_by_its_own_queries(centred, tmp_path):
    # val [40, 46): 6 queries; L = 5 needs 5 + 2 = 7, L = 3 needs 5. train and test (40 queries) are long enough:
    # checked with their own shape, not with L queries
    with pytest.raises(ConfigError) as error:
        preflight(validate(_config(tmp_path, {"matcher": "centred"})))
    message = str(error.value)
    assert ("datasets.sample: split 'val' (references [40, 46), queries [40, 46)) cannot be matched by the matcher "
            "centred (extra 2) (sequence_matching) at sequence length 5: split 'val' has 6 queries; this matcher "
            "needs 7; lengthen the split (its reference or query range), or change sequence_matching") in message
    assert "'train'" not in message and "'test'" not in message
    assert not (tmp_path / "out").exists()  # nothing ran
    plan = preflight(validate(_config(tmp_path, {"matcher": "centred", "extra": 1})))  # 6 queries suffice
    assert plan.datasets["sample"].splits["val"] == (40, 46)


def test_the_plan_checks_the_compared_matchers_at_the_tables_sequence_length(centred, tmp_path):
    # the run's matcher is seqslam (6 queries are enough at L = 3 and 5); the experiment matchers compares centred at
    # table_seq_len 5, which needs 5 + 2 = 7 queries of val [40, 46): refused before any job, naming the setting
    conf = {**_config(tmp_path, {"matcher": "seqslam"}), "table_seq_len": 5, "experiments": {"speed": False},
            "matchers": [{"matcher": "seqslam"}, {"matcher": "centred"}]}
    with pytest.raises(ConfigError) as error:
        preflight(validate(conf))
    message = str(error.value)
    assert ("datasets.sample: split 'val' (references [40, 46), queries [40, 46)) cannot be matched by the matcher "
            "centred (extra 2) (matchers) at sequence length 5: split 'val' has 6 queries; this matcher needs 7; "
            "lengthen the split (its reference or query range), or change matchers (or switch the experiment off: "
            "experiments.matchers: false)") in message
    assert "sequence_matching" not in message
    # at table_seq_len 3 it needs 5, but the experiment adaptive_seq_len runs it at L = 5 too: refused, naming that
    # experiment as the other way out; without it the plan passes; switched off, the experiment checks nothing
    with pytest.raises(ConfigError) as error:
        preflight(validate({**conf, "table_seq_len": 3}))
    assert ("at sequence length 5: split 'val' has 6 queries; this matcher needs 7; lengthen the split (its "
            "reference or query range), or change matchers (or switch the experiment off: "
            "experiments.adaptive_seq_len: false, which runs the compared matchers at every length of seq_lens)"
            ) in str(error.value)
    preflight(validate({**conf, "table_seq_len": 3, "experiments": {"speed": False, "adaptive_seq_len": False}}))
    preflight(validate({**conf, "experiments": {"speed": False, "matchers": False}}))
