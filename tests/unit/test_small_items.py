"""Small user-facing promises, each on matrices no other test uses: the advice on a matrix too small for the
sequence length asked can be followed (a length it names works; none is named below the shortest); a constant or
all-tied matrix is named as such."""

import re

import numpy as np
import pytest

from vpr_smr.eval.matching import attributes
from vpr_smr.eval.matching.checks import check_size, tie_warning
from vpr_smr.eval.matching.matchers import MATCHERS, MatcherSpec
from vpr_smr.eval.scoring import vpr_metrics
from vpr_smr.eval.scoring.vpr_metrics import MatcherSettings


def _refuse_above(longest):
    def check(seq_len):
        if seq_len > longest:
            raise ValueError(f"m does not fit {seq_len}")
    return check


@pytest.mark.parametrize("longest", [2, 3, 7, 64])
def test_the_advised_length_is_the_longest_that_fits(longest):
    with pytest.raises(ValueError, match=rf"^m does not fit 100; give a --seq-len of at most {longest}, or a larger "
                                         r"matrix$"):
        check_size(_refuse_above(longest), 100)
    check_size(_refuse_above(longest), longest)  # fits: no error


def test_a_matrix_no_length_fits_is_named_so_and_a_length_below_two_is_refused_first():
    with pytest.raises(ValueError, match=r"^m does not fit 2; 2 is the shortest sequence length, so no --seq-len "
                                         r"fits: give a larger matrix$"):
        check_size(_refuse_above(1), 5)
    with pytest.raises(ValueError, match=r"^--seq-len must be at least 2 \(.*\), got 1; besides, m does not fit 2; "):
        check_size(_refuse_above(1), 1)
    with pytest.raises(ValueError, match=r"^--seq-len must be at least 2 \(.*\), got 0$"):
        check_size(_refuse_above(9), 0)


def _stages(tmp_path, matcher):
    """The stages that match a matrix at a length: attributes, and metrics (queries shares its reading)."""
    spec = MatcherSpec.of(matcher)
    return {
        "attributes": lambda path, seq_len: attributes.main(path, tmp_path / "a.csv", seq_len, 0, matcher=spec),
        "metrics": lambda path, seq_len: vpr_metrics.main({"s": path}, seq_len, 0, tmp_path / "m.json",
                                                          matcher=MatcherSettings(spec), baselines=None),
    }


@pytest.mark.parametrize("matcher", sorted(MATCHERS))
@pytest.mark.parametrize("size", [1, 3, 14])
def test_every_matchers_advice_on_a_small_matrix_can_be_followed(tmp_path, matcher, size):
    path = tmp_path / f"d{size}.npy"
    rng = np.random.default_rng(size)
    np.save(path, rng.random((size, size)) + 5 * np.abs(np.subtract.outer(np.arange(size), np.arange(size))))
    for stage, run in _stages(tmp_path, matcher).items():
        try:
            run(path, 9)
            continue  # fits even 9
        except ValueError as error:
            message = str(error)
        assert "at most 1" not in message and "at most 0" not in message, (stage, message)
        advised = re.search(r"give a --seq-len of at most (\d+)", message)
        if advised is None:  # nothing fits: said in words, and the shortest length is refused too
            assert "so no --seq-len fits: give a larger matrix" in message, (stage, message)
            with pytest.raises(ValueError, match="no --seq-len fits"):
                run(path, 2)
        else:
            run(path, int(advised.group(1)))  # the advice works


def _tie_warnings(caplog):
    return [r.getMessage() for r in caplog.records if r.levelname == "WARNING" and "single value" in r.getMessage()]


@pytest.mark.parametrize("stage", ["attributes", "metrics"])
@pytest.mark.parametrize("values", [
    np.full((12, 12), 5.0),  # constant
    np.zeros((12, 12)),  # constant at 0
    np.tile(np.arange(12.0) * 3, (12, 1)),  # each column one value, another per column: all tied
])
def test_a_constant_or_all_tied_matrix_is_named_as_such(tmp_path, caplog, stage, values):
    path = tmp_path / "flat.npy"
    np.save(path, values)
    _stages(tmp_path, "seqslam")[stage](path, 3)
    warnings = _tie_warnings(caplog)
    assert len(warnings) == 1 and warnings[0].startswith(str(path)), warnings
    assert "every one of its 12 query columns holds a single value" in warnings[0]
    assert "every ranking is a tie" in warnings[0] and "not by the matrix" in warnings[0]


def test_tied_columns_are_counted_and_a_matrix_without_ties_passes_silently(tmp_path, caplog):
    rng = np.random.default_rng(44)
    values = rng.random((15, 15)) + 3 * np.abs(np.subtract.outer(np.arange(15), np.arange(15)))
    np.save(tmp_path / "plain.npy", values)
    values[:, [2, 9, 11]] = 7.25  # three queries whose every reference is equally far
    values[4, 5] = np.nan  # a NaN column is no tie (and is refused later, naming the value)
    np.save(tmp_path / "three.npy", values[:, :-1])
    _stages(tmp_path, "seqslam")["metrics"](tmp_path / "plain.npy", 3)
    assert _tie_warnings(caplog) == []
    assert tie_warning("three.npy", values[:, :-1]) == (
        "three.npy: 3 of its 14 query columns hold a single value: those queries' single-frame rankings are ties, "
        "decided by how ties are broken, not by the matrix")
    wide = np.tile(rng.random((1, 1000)), (6, 1))  # a sample of 256 of 1000 columns, every one tied
    assert tie_warning("wide", wide).startswith("wide: every one of 256 of its 1000 query columns read holds")
