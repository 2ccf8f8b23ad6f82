"""Small user-facing promises, each on matrices no other test uses: the advice on a matrix too small for the
sequence length asked can be followed (a length it names works; none is named below the shortest)."""

import re

import numpy as np
import pytest

from vpr_smr.eval.matching import attributes
from vpr_smr.eval.matching.checks import check_size
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
