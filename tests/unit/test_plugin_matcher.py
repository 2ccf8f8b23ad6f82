"""A matcher that is a plugin: ``toy`` (tests/plugins), registered only by its dist-info's entry point, found by the
registry, built from a spec, and matching as a naive implementation of its rule does, block by block as on the
whole split."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from toy_plugin import PLUGIN_SITE, plugin_env, toy_rule

from vpr_smr.eval.matching.matchers import MatcherSpec, available_matchers, matcher_class


@pytest.fixture
def toy(monkeypatch):
    """The plugin's site folder on sys.path, as a ``pip install`` would put it (importlib.metadata reads it)."""
    monkeypatch.syspath_prepend(str(PLUGIN_SITE))
    import toy_matcher

    return toy_matcher


def run_blocks(spec: MatcherSpec, d: np.ndarray, cuts: list[int]):
    """The matcher over the columns of ``d`` in blocks cut at ``cuts``, the state carried along; the blocks
    concatenated."""
    matcher = spec.build(3)
    matcher.check(d.shape)
    state = matcher.initial_state()
    blocks = []
    for lo, hi in zip([0, *cuts], [*cuts, d.shape[1]], strict=True):
        block, state = matcher.block(d[:, lo:hi].T, lo, state)
        blocks.append(block)
    return (np.concatenate([b.queries for b in blocks]), np.concatenate([b.scores for b in blocks]),
            np.concatenate([b.match for b in blocks]), np.concatenate([b.native for b in blocks]))


def test_unseen_without_its_site_folder():
    assert "toy" not in available_matchers()
    with pytest.raises(ValueError, match="unknown sequence matcher 'toy'; available: .*seqslam"):
        matcher_class("toy")


def test_the_registry_finds_it_by_its_entry_point(toy):
    assert {"seqslam", "toy"} <= set(available_matchers())
    assert matcher_class("toy") is toy.ToyMatcher


def test_a_process_given_the_folder_on_pythonpath_finds_it():
    """What the workflow test relies on: Snakemake's jobs inherit PYTHONPATH."""
    code = "from vpr_smr.eval.matching.matchers import matcher_class; print(matcher_class('toy').description)"
    out = subprocess.run([sys.executable, "-c", code], env=plugin_env(), capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "a fading sum of distances along the diagonal (a test plugin)"


def test_its_spec_fills_defaults_records_and_reads_back(toy):
    spec = MatcherSpec.of("toy", {"decay": 0.25})
    assert spec.values == {"decay": 0.25, "step": 1}
    assert spec.record() == toy.ToySettings(decay=0.25, step=1)
    assert spec.provenance() == {"name": "toy", "settings": {"decay": 0.25, "step": 1}}
    assert MatcherSpec.from_provenance({"name": "toy", "settings": {"decay": 0.25}}, "f.h5") == spec
    assert spec != MatcherSpec.of("toy") and MatcherSpec.of("toy").values == {"decay": 0.5, "step": 1}
    assert str(spec) == "toy (decay 0.25, step 1)"
    assert len({spec, MatcherSpec.of("toy", {"step": 1, "decay": 0.25})}) == 1
    built = spec.build(4)
    assert isinstance(built, toy.ToyMatcher) and built.settings == toy.ToySettings(0.25, 1)
    assert (built.lookback, built.lookahead, built.evaluated(7)) == (0, 0, (0, 7))  # a filter: every query


def test_its_settings_are_checked_against_their_declarations(toy):
    with pytest.raises(ValueError, match=r"sequence_matching\.decay: .*must be <= 1, got 2\.0"):
        MatcherSpec.of("toy", {"decay": 2})
    with pytest.raises(ValueError, match=r"sequence_matching\.step: expected an integer, got 0\.5"):
        MatcherSpec.of("toy", {"step": 0.5})
    with pytest.raises(ValueError, match=r"sequence_matching\.decya: unexpected setting 'decya'.*decay"):
        MatcherSpec.of("toy", {"decya": 0.5})


def test_a_matrix_by_hand(toy):
    d = np.array([[1.0, 4.0, 2.0],
                  [3.0, 0.0, 5.0],
                  [2.0, 2.0, 1.0]])
    # query 0: [1, 3, 2]; query 1: [4, 0, 2] + 0.5 [1, 1, 3] = [4.5, 0.5, 3.5];
    # query 2: [2, 5, 1] + 0.5 [4.5, 4.5, 0.5] = [4.25, 7.25, 1.25]
    queries, scores, match, native = run_blocks(MatcherSpec.of("toy"), d, [])
    np.testing.assert_array_equal(queries, [0, 1, 2])
    np.testing.assert_array_equal(scores, [[1, 3, 2], [4.5, 0.5, 3.5], [4.25, 7.25, 1.25]])
    np.testing.assert_array_equal(match, [0, 1, 2])
    np.testing.assert_array_equal(native, [1.0, 3.0, 3.0])  # second best minus best
    assert scores.dtype == np.float64 and match.dtype == np.int64


@pytest.mark.parametrize("settings", [{}, {"decay": 0.9, "step": 2}, {"decay": 0.0, "step": 0}])
def test_block_wise_equals_the_whole_split_and_the_naive_rule(toy, settings):
    d = np.random.default_rng(5).random((12, 17))
    d[3, 4] = d[5, 4] = 0.0  # a tie at query 4 (decay 0): the lowest reference wins
    spec = MatcherSpec.of("toy", settings)
    scores, matches, margins = toy_rule(d, spec.values["decay"], spec.values["step"])
    whole = run_blocks(spec, d, [])
    np.testing.assert_array_equal(whole[0], np.arange(17))
    np.testing.assert_allclose(whole[1], scores, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(whole[2], matches)
    np.testing.assert_allclose(whole[3], margins, rtol=0, atol=1e-12)
    for cuts in ([1], [5, 6, 11], list(range(1, 17))):
        blocks = run_blocks(spec, d, cuts)
        for got, expected in zip(blocks, whole, strict=True):
            np.testing.assert_array_equal(got, expected)  # bit for bit


def test_a_matrix_it_cannot_match_is_refused(toy):
    matcher = MatcherSpec.of("toy").build(3)
    with pytest.raises(ValueError, match=r"D of the test split has shape \(1, 5\); the toy matcher needs .* 2 "):
        matcher.check((1, 5), "D of the test split")


def test_vpr_smr_matchers_lists_it_with_its_settings(toy, capsys):
    from vpr_smr.pipeline.cli import main

    assert main(["matchers"]) in (0, None)
    out = capsys.readouterr().out.splitlines()
    assert any(line.startswith("seqslam (the default): SeqSLAM") for line in out)
    assert "  native confidence: the training-free scorer uniqueness" in out
    assert "  velocities (--velocities, default [1.0]): velocities searched, in reference frames per query frame " \
           "([1.0]: the fixed matcher)" in out
    at = out.index("toy: a fading sum of distances along the diagonal (a test plugin)")
    assert out[at + 1] == "  native confidence: its own, per query (the training-free scorer native)"
    assert out[at + 2].startswith("  decay (--decay, default 0.5): ")
    assert out[at + 3].startswith("  step (--step, default 1): ")


def test_an_unknown_matcher_on_the_command_line_is_named_with_the_available_ones(tmp_path, capsys):
    from vpr_smr.pipeline.cli import main

    np.save(tmp_path / "d.npy", np.ones((5, 5)))
    assert main(["attributes", "--distances", str(tmp_path / "d.npy"), "--seq-len", "3", "--matcher", "seqslm",
                 "--out", str(tmp_path / "a.h5")]) != 0
    err = capsys.readouterr().err
    assert ("unknown sequence matcher 'seqslm' (did you mean 'seqslam'?); available: "
            f"{', '.join(available_matchers())} (a package") in err
    assert not (tmp_path / "a.h5").exists()
