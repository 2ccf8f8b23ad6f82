"""The report's prose lives in ``eval/report/templates/sections.yaml`` (``sections.prose``): each text there is the
intro of the section of its id (the page's own, ``html.SECTIONS``, or an experiment's, declared in its module), in
the page's order, and the page shows it as written."""

from __future__ import annotations

import pytest
import yaml

from vpr_smr.eval.report import experiments, html, sections
from vpr_smr.eval.report.tables import matchers


def test_each_intro_of_the_file_is_its_sections():
    texts = yaml.safe_load(sections.PROSE.read_text(encoding="utf-8"))
    installed = {entry.section for experiment in experiments.installed() for entry in experiment.tables}
    intros = {spec.id: spec.intro for spec in html.declared_sections()  # an installed experiment's: its own text
              if isinstance(spec.intro, str) and spec not in installed}
    assert list(texts) == list(intros)  # every section with a plain intro, in the page's order
    for name, text in texts.items():
        assert intros[name] == (text.replace("{far_below}", f"{matchers.FAR_BELOW:g}") if name == "matchers"
                                else text)
    # a folded block: its lines joined by one space, no line break left
    assert intros["timing"] == ("Time per query of the attributes and of the prediction (this machine; every other "
                                "number of the report repeats exactly, this one does not).")
    assert f"is under {matchers.FAR_BELOW:g} of the fixed matcher's is flagged" in intros["matchers"]


def test_an_unknown_section_names_the_file():
    with pytest.raises(KeyError, match=r"sections\.yaml has no intro of the section 'nothing'; it has matchers, "):
        sections.prose("nothing")
