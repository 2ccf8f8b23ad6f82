"""A table's row is a typed record: its fields declare its columns (eval/report/rows.py), the registry takes them
from it, and the writer writes the record's cells."""

from __future__ import annotations

import csv
import dataclasses
from collections.abc import Mapping

import pytest

from vpr_smr.eval.report import registry, rows
from vpr_smr.eval.report.build import _write_table
from vpr_smr.eval.report.results import Splits
from vpr_smr.eval.report.rows import cells, column, each, extra, interval
from vpr_smr.eval.scoring.records import Interval, SplitTiming


@dataclasses.dataclass(frozen=True)
class Toy:
    """Every kind of field: a shared column, its interval, labelled ones, a mapping per key and per split, an
    extra."""

    seq_len: int = column()
    reduction_pct: float | None = column()
    reduction_pct_ci: Interval | None = interval()
    aoc: float = column("AOC", ".3f")
    aoc_ci: Interval | None = interval()
    gap_ci: Interval | None = interval("gap (%)", ".1f")
    recall: Mapping[int, float] = each((1, 5), "recall_at_{}", "R@{}")
    f1: Mapping[str, float] = each((), "f1_{evaluation}", "F1 {word}")
    note: str = extra("")


def test_a_record_declares_its_columns_headers_and_formats():
    found = [(c.name, c.header, c.fmt) for c in registry.expand(rows.columns(Toy), Splits("test", ("val", "test")))]
    assert found == [
        ("seq_len", "L", ".4f"),  # rows.SHARED's header
        ("reduction_pct", "AOC reduction (%)", ".2f"),
        ("reduction_pct_ci_low", "AOC reduction (%), low", ".2f"),  # the number's header and format
        ("reduction_pct_ci_high", "AOC reduction (%), high", ".2f"),
        ("aoc", "AOC", ".3f"),
        ("aoc_ci_low", "AOC, low", ".3f"),  # the record's own column's, not a shared one's
        ("aoc_ci_high", "AOC, high", ".3f"),
        ("gap_ci_low", "gap (%), low", ".1f"),  # an interval of no column: its own label
        ("gap_ci_high", "gap (%), high", ".1f"),
        ("recall_at_1", "R@1", ".4f"), ("recall_at_5", "R@5", ".4f"),
        ("f1_val", "F1 validation", ".4f"), ("f1_test", "F1 test", ".4f"),  # one per evaluation split
    ]  # the extra is no column


def test_a_rows_cells_are_its_columns_by_name_and_its_extras():
    row = Toy(4, None, None, 0.25, Interval(0.1, 0.4), Interval(-1.0, 2.0), {1: 0.5, 5: 0.75}, {"test": 0.6}, "x")
    assert cells(row) == {
        "seq_len": 4, "reduction_pct": None, "reduction_pct_ci_low": None, "reduction_pct_ci_high": None,
        "aoc": 0.25, "aoc_ci_low": 0.1, "aoc_ci_high": 0.4, "gap_ci_low": -1.0, "gap_ci_high": 2.0,
        "recall_at_1": 0.5, "recall_at_5": 0.75, "f1_test": 0.6, "note": "x"}  # f1_val: the row has none


def test_a_row_parses_back_from_its_cells():
    row = Toy(4, None, None, 0.25, Interval(0.1, 0.4), Interval(-1.0, 2.0), {1: 0.5, 5: 0.75}, {"test": 0.6}, "x")
    splits = Splits("test", ("val", "test"))
    assert rows.parse(Toy, cells(row), splits) == row
    # the cells of a CSV row, which name its columns only: the extra is missing, and said
    found = {**cells(row), "f1_val": 0.3}
    del found["note"]
    with pytest.raises(KeyError, match="a Toy row has a column 'note'"):
        rows.parse(Toy, found, splits)
    # a split's column parses as that split's value, a column per split needs the splits
    assert rows.parse(Toy, {**found, "note": ""}, splits).f1 == {"val": 0.3, "test": 0.6}
    with pytest.raises(ValueError, match="Toy.f1 is a column per split"):
        rows.parse(Toy, cells(row))


def test_a_field_not_declared_as_a_column_is_refused_naming_it():
    @dataclasses.dataclass(frozen=True)
    class Plain:
        dataset: str = column()
        method: str = "m"

    with pytest.raises(TypeError, match="row field 'method' is not declared by eval/report/rows.py"):
        rows.columns(Plain)

    @dataclasses.dataclass(frozen=True)
    class Misnamed:
        bounds: Interval | None = interval()

    with pytest.raises(TypeError, match="interval field 'bounds': name it <number>_ci"):
        rows.columns(Misnamed)


def test_every_registered_table_is_a_typed_row_with_declared_columns():
    for spec in registry.TABLES:
        assert dataclasses.is_dataclass(spec.row) and spec.row.__dataclass_params__.frozen, spec.name
        names = [c.name for c in spec.columns]
        assert names and len(names) == len(set(names)), spec.name


def test_the_writer_writes_a_typed_rows_cells(tmp_path):
    # 0.2 s of attributes and 0.1 s of prediction over 100 queries: 3 ms per query, 2 of them the attributes'
    row = rows.TimingRow.of("d", "m", 4, "test", SplitTiming.of(0.2, 0.1, 100))
    spec = registry.table("timing")
    stem = tmp_path / "timing"
    _write_table(stem, spec.names(), [cells(row)], spec.title)
    (written,) = csv.DictReader(open(stem.with_suffix(".csv")))
    assert {k: float(written[k]) for k in ("ms_per_query", "ms_attributes_per_query", "ms_predict_per_query")} == (
        pytest.approx({"ms_per_query": 3.0, "ms_attributes_per_query": 2.0, "ms_predict_per_query": 1.0}))
    assert stem.with_suffix(".md").read_text().splitlines()[-1] == (
        "| d | m | 4 | test | 100 | 0.2000 | 0.1000 | 3.0000 | 2.0000 | 1.0000 |")


def test_every_registered_table_is_shown_by_a_declared_section():
    from vpr_smr.eval.report.html import declared_sections

    sections = declared_sections()  # the page's, then those the tables declare
    shown = [name for section in sections for name in section.tables]
    # the datasets table is folded under the dataset cards, not in an experiment's section
    assert sorted([*shown, "datasets"]) == sorted(spec.name for spec in registry.TABLES)
    assert len({section.id for section in sections}) == len(sections)


def test_the_names_the_report_reads_are_the_row_records_fields():
    from vpr_smr.eval.report import names

    fields = {field.name for field in dataclasses.fields(rows.Table1Row)}
    assert {names.REDUCTION, names.AOC_VPR_SM, names.AOC_VPR_SM_PRED, names.RECALL_SINGLE,
            names.RECALL_SEQUENCE} <= fields
    assert {"reduction_pct", "aoc_vpr_sm", "aoc_vpr_sm_pred", "recall_at_1_single", "recall_at_1_sequence"} == {
        names.REDUCTION, names.AOC_VPR_SM, names.AOC_VPR_SM_PRED, names.RECALL_SINGLE, names.RECALL_SEQUENCE}
