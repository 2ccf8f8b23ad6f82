"""The page's sections: its own (``html.SECTIONS``) and the experiments' (each declared in its module, on its table),
placed by their ``after`` (``sections.placed``)."""

from __future__ import annotations

import pytest

from vpr_smr.eval.report import experiments, html
from vpr_smr.eval.report.sections import Declared, placed

# the page's order before the experiments declared their sections in their modules (html.SECTIONS held them all)
PAGE = ("baselines", "matchers", "deployment", "pr-curves", "trust-levels", "restoration", "sequence-length",
        "adaptive-seq-len", "speed", "predictor", "table-ii", "leave-one-method-out", "timing", "vpr-metrics",
        "protocol-sweep", "match-inspector")


def _section(name: str, after: str = "") -> Declared:
    return Declared(name, name, (), "", after=after)


def test_a_section_goes_after_the_one_it_names_and_those_placed_there_before_it():
    own = [_section("a"), _section("b"), _section("c")]
    # y follows x, which is placed later in the list's order; z follows b too, after x and what follows x
    more = [_section("y", "x"), _section("x", "b"), _section("z", "b"), _section("w")]
    assert [spec.id for spec in placed(own, more)] == ["a", "b", "x", "y", "z", "c", "w"]
    with pytest.raises(ValueError, match="section 'v' follows 'nothing', which is no section's id"):
        placed(own, [_section("v", "nothing")])


def test_the_tool_s_own_experiments_declare_their_sections_in_the_page_s_order():
    sections = [spec for spec in html.declared_sections() if spec.id in PAGE]
    assert tuple(spec.id for spec in sections) == PAGE
    own = {entry.section.id for experiment in experiments.builtin() for entry in experiment.tables
           if entry.section is not None}
    assert own == {"matchers", "trust-levels", "restoration", "adaptive-seq-len", "speed", "protocol-sweep",
                   "deployment"}
    assert not own & {spec.id for spec in html.SECTIONS}  # the page's module names none of them
