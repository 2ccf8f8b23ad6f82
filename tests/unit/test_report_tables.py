"""The registry collects the tables declared one module each in ``eval/report/tables/`` and refuses a module that
declares none, or a table declared twice."""

from __future__ import annotations

import sys

import pytest

from vpr_smr.eval.report import registry, tables


@pytest.fixture
def more_tables(tmp_path, monkeypatch):
    """A folder added to ``eval/report/tables``' path; its modules' names leave ``sys.modules`` after the test."""
    folder = tmp_path / "more"
    folder.mkdir()
    monkeypatch.setattr(tables, "__path__", [*tables.__path__, str(folder)])
    yield folder
    for module in folder.glob("*.py"):
        sys.modules.pop(f"vpr_smr.eval.report.tables.{module.stem}", None)


def test_the_datasets_table_is_one_module_collected_after_the_core_tables():
    from vpr_smr.eval.report.tables import adaptive, datasets, deployment, matchers

    assert registry.TABLES == (*registry.CORE_TABLES, adaptive.TABLE, datasets.TABLE, deployment.TABLE,
                               matchers.TABLE)  # by name
    assert registry.table("datasets") is datasets.TABLE and not datasets.TABLE.protocol


def test_a_module_without_a_table_is_refused(more_tables):
    (more_tables / "helpers_only.py").write_text("VALUE = 1\n")
    with pytest.raises(TypeError, match=r"helpers_only\.py declares no TABLE \(a registry\.Table\): each module of "
                                        r"vpr_smr\.eval\.report\.tables is one table of the report"):
        registry.declared()


def test_a_table_declared_twice_is_refused(more_tables):
    (more_tables / "timing_again.py").write_text(
        "from dataclasses import replace\n\nfrom vpr_smr.eval.report import registry\n\n"
        "TABLE = replace(registry.table('timing'))\n")
    with pytest.raises(ValueError, match="tables declared twice: timing"):
        registry.collected(*registry.CORE_TABLES, *registry.declared())


def test_an_unknown_table_names_both_places_to_declare_one():
    with pytest.raises(KeyError, match="not in eval/report/registry.py CORE_TABLES nor declared by a module of "
                                       "eval/report/tables/"):
        registry.table("nowhere")
