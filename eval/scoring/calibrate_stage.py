"""The ``calibrate`` and ``deploy`` stages (method §16): a threshold set on a calibration split, written to a
threshold file (``threshold_file``), and that file applied to another split.

Either stage reads a split's confidences and labels from the per-query table of ``vpr-smr queries`` (``--queries
queries.csv --split val``: the ``c_<source>`` column and ``sequence_correct``) or computes that table in memory
from the matrices ``vpr-smr queries`` takes (``--distances val=val.h5 --seq-len 4 ...``: the queries stage's own
``score_all`` and rows, so that both inputs give the same numbers). The rules are ``thresholds``'; this module checks
the inputs (each refusal names the setting and the fix, before anything is written), runs them and writes the
files.
"""

from __future__ import annotations

import csv
import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.io import CSV_SUFFIXES, JSON_SUFFIXES, atomic_path, check_suffix, write_json
from vpr_smr.core.records import Record, encode
from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.eval.matching import sources
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.sources import MatrixFormat, TruthSource
from vpr_smr.eval.predictor.defaults import allow_split_overlap
from vpr_smr.eval.scoring import thresholds
from vpr_smr.eval.scoring.scorers import PREDICTOR, BaselineSettings, baseline_settings
from vpr_smr.eval.scoring.threshold_file import (
    REFUSED_SOURCES,
    ThresholdFile,
    check_same,
    read_thresholds,
    write_thresholds,
)
from vpr_smr.eval.scoring.thresholds import (
    DEFAULT_RISK,
    DEFAULT_SEGMENT,
    GUARANTEED,
    RULES,
    Calibration,
    Realised,
    Segments,
)

__all__ = ["CalibrateJob", "Calibrated", "DeployJob", "Deployed", "DeployedSplit", "SplitTable", "calibrate",
           "calibrate_main", "deploy", "deploy_main", "read_split"]

log = logging.getLogger("vpr_smr")

CALIBRATION_SPLIT = "val"  # method §16: the calibration split is the validation split unless told


# --- the job records: the inputs both stages read alike ----------------------------------------------------------


def _queries() -> Any:
    return setting(None, "the per-query table (CSV) of vpr-smr queries; or give --distances", metavar="PATH")


def _split(default: str) -> Any:
    return setting(None, f"the split of the table or of --distances ({default}; a single split needs none)",
                   metavar="NAME")


def _distances() -> Any:
    return setting((), "instead of --queries: the matrices vpr-smr queries takes (one file, or SPLIT=PATH items), "
                       "scored here in memory as vpr-smr queries scores them", metavar="PATH or SPLIT=PATH")


def _method() -> Any:
    return setting(None, "the method whose matrices the confidences come from (the table does not record it): "
                         "written in the threshold file, which deploy and the live matcher compare", metavar="NAME")


def _predictor() -> Any:
    return setting(None, "the seed-0 predictor (.h5): with --distances it gives c_predictor; with source predictor "
                         "its SHA-256 is written in (or compared with) the threshold file", metavar="PATH")


def _attributes() -> Any:
    return setting(None, "with --distances: the splits' attributes (.h5) computed from the same matrices",
                   metavar="SPLIT=PATH")


@dataclass(frozen=True)
class CalibrateJob:
    """The ``calibrate`` stage's job: a rule's threshold on a calibration split, written as a threshold file."""

    source: str = setting(REQUIRED, "the confidence to threshold: a scorer of method §12 (the table's c_<source> "
                                    "columns, e.g. uniqueness, predictor, native; not random)", metavar="NAME")
    precision: float = setting(0.9, "the target precision p, in (0, 1]", exclusive_minimum=0, maximum=1)
    rule: str = setting(GUARANTEED, "empirical (the smallest threshold reaching p on the split), guaranteed "
                                    "(precision at least p with probability 1 - risk on exchangeable queries) or "
                                    "same_fraction (the fraction empirical accepts)", choices=RULES)
    risk: float = setting(DEFAULT_RISK, "guaranteed's risk delta, in (0, 1)", exclusive_minimum=0, maximum=1)
    queries: str | None = _queries()
    split: str | None = _split(f"default {CALIBRATION_SPLIT} where the input has it")
    distances: tuple[str, ...] = _distances()
    seq_len: int | None = setting(None, "the sequence length L (required with --distances; with --queries written "
                                        "in the threshold file, which the table does not record)", minimum=1)
    method: str | None = _method()
    truth: TruthSource = sources.truth()
    matcher: MatcherSpec = sources.matcher()
    matrix: MatrixFormat = sources.matrix()
    predictor: str | None = _predictor()
    attributes: dict[str, str] | None = _attributes()
    scorers: BaselineSettings = baseline_settings()
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the threshold file (JSON)", metavar="PATH")


@dataclass(frozen=True)
class DeployJob:
    """The ``deploy`` stage's job: a threshold file applied to another split."""

    thresholds: str = setting(REQUIRED, "the threshold file of vpr-smr calibrate", metavar="PATH")
    queries: str | None = _queries()
    split: str | None = _split("required where the input has several")
    distances: tuple[str, ...] = _distances()
    seq_len: int | None = setting(None, "the sequence length L (default with --distances: the threshold file's)",
                                  minimum=1)
    method: str | None = _method()
    truth: TruthSource = sources.truth()
    matcher: MatcherSpec = sources.matcher()
    matrix: MatrixFormat = sources.matrix()
    predictor: str | None = _predictor()
    attributes: dict[str, str] | None = _attributes()
    scorers: BaselineSettings = baseline_settings()
    allow_split_overlap: bool = allow_split_overlap()
    segment: int = setting(DEFAULT_SEGMENT, "queries per segment: the share of consecutive segments whose precision "
                                            "is below the target", minimum=1)
    accepted: str | None = setting(None, "also write the split's queries with their confidence and whether they are "
                                         "accepted (CSV)", metavar="PATH")
    out: str = setting(REQUIRED, "what the threshold does on the split (JSON)", metavar="PATH")


# --- a split's confidences and labels -----------------------------------------------------------------------------


@dataclass(frozen=True)
class SplitTable:
    """One split of the per-query table as the rules take it: the queries (dataset frames), their sequence
    matches, one source's confidence, the labels (None: the table has none) and the matcher that made the
    matches (the table's ``matcher`` cell)."""

    split: str
    query: np.ndarray
    sequence_match: np.ndarray
    confidence: np.ndarray
    correct: np.ndarray | None
    matcher: str
    where: str  # the input, for messages


def _table_rows(path: str) -> tuple[list[str], list[dict[str, str]]]:
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"--queries {path}: no such file; write it with vpr-smr queries")
    with open(file, newline="") as handle:
        reader = csv.DictReader(handle)
        header, rows = list(reader.fieldnames or []), list(reader)
    if "split" not in header or "sequence_correct" not in header:
        raise ValueError(f"--queries {path}: not a per-query table of vpr-smr queries (no split and sequence_correct "
                         "columns); write it with vpr-smr queries")
    return header, rows


def _matrix_rows(job: CalibrateJob | DeployJob, seq_len: int | None) -> tuple[list[str], list[dict[str, str]]]:
    """The per-query table of ``--distances`` computed in memory, by the queries stage's own code."""
    from vpr_smr.eval.scoring.matrix_jobs import QueriesJob
    from vpr_smr.eval.scoring.queries import QUERY_COLUMNS, query_rows, score_columns
    from vpr_smr.eval.scoring.vpr_metrics import score_all

    if seq_len is None:
        raise ValueError("--distances needs --seq-len L, the sequence length of the matching")
    scored = score_all(QueriesJob(job.distances, seq_len, job.truth, job.matcher, job.matrix, job.predictor,
                                  job.attributes, True, job.scorers, job.allow_split_overlap, out="(in memory)"))
    header = [*QUERY_COLUMNS, *score_columns()]
    rows = [dict(zip(header, row, strict=True)) for one in scored.splits.values() for row in query_rows(one.queries)]
    return header, rows


def _where(job: CalibrateJob | DeployJob) -> str:
    if (job.queries is None) == (not job.distances):
        raise ValueError("give the split's per-query table (--queries queries.csv) or its matrices (--distances "
                         "SPLIT=PATH ...), one of them")
    return f"--queries {job.queries}" if job.queries is not None else "--distances"


def read_split(job: CalibrateJob | DeployJob, source: str, default_split: str | None,
               seq_len: int | None = None) -> SplitTable:
    """``source``'s confidences and the labels of one split of the job's input; ValueError naming the setting and
    the fix (an unknown source lists the table's, a missing split lists its splits)."""
    where = _where(job)
    header, rows = _table_rows(job.queries) if job.queries is not None else _matrix_rows(job, seq_len)
    column = f"c_{source}"
    sources_found = [name.removeprefix("c_") for name in header
                     if name.startswith("c_") and name.removeprefix("c_") not in REFUSED_SOURCES]
    if source in REFUSED_SOURCES:
        raise ValueError(f"--source {source}: a random order has nothing to calibrate; choose one of "
                         f"{', '.join(sources_found)}")
    if column not in header:
        raise ValueError(f"--source {source}: {where} has no column {column}; its sources: "
                         f"{', '.join(sources_found) or 'none (a table of vpr-smr queries --no-baselines)'}")
    splits = list(dict.fromkeys(row["split"] for row in rows))
    split = job.split
    if split is None:
        split = default_split if default_split in splits else splits[0] if len(splits) == 1 else None
    if split is None or split not in splits:
        shown = "none given" if split is None else f"{split!r} is not one of them"
        raise ValueError(f"--split: {where} holds the splits {', '.join(splits) or '(none)'} ({shown}): give one "
                         "with --split NAME")
    mine = [row for row in rows if row["split"] == split]
    cells = [row[column] for row in mine]
    if any(cell == "" for cell in cells):
        fix = " (give --predictor to vpr-smr queries)" if source == PREDICTOR else ""
        raise ValueError(f"--source {source}: {where} split {split} has no {column} value for some queries{fix}")
    try:
        values = np.array([float(cell) for cell in cells], dtype=np.float64)
    except ValueError:
        raise ValueError(f"--source {source}: {where} split {split} has a {column} value that is no number: give "
                         "the table vpr-smr queries wrote") from None
    labels = [row["sequence_correct"] for row in mine]
    if any(cell not in ("", "0", "1") for cell in labels):
        raise ValueError(f"{where} split {split}: sequence_correct holds values other than 0, 1 or empty: give the "
                         "table vpr-smr queries wrote")
    if any(cell == "" for cell in labels) and not all(cell == "" for cell in labels):
        raise ValueError(f"{where} split {split}: sequence_correct is empty for some queries only; give a table "
                         "whose split is labelled throughout, or not at all")
    matchers = {row.get("matcher", "") for row in mine}
    if len(matchers) != 1:
        raise ValueError(f"{where} split {split}: its rows name {len(matchers)} matchers; give one matcher's table")
    return SplitTable(
        split, np.array([int(row["query"]) for row in mine], dtype=np.int64),
        np.array([int(row["sequence_match"]) for row in mine], dtype=np.int64),
        values,
        None if all(cell == "" for cell in labels) else np.array([cell == "1" for cell in labels], dtype=bool),
        matchers.pop(), f"{where} split {split}")


def _input_matcher(job: CalibrateJob | DeployJob, table: SplitTable) -> str:
    """The matcher that made the table's matches; a ``--matcher`` other than the default that differs is refused."""
    given = str(job.matcher)
    if job.queries is not None and job.matcher != MatcherSpec.of() and given != table.matcher:
        raise ValueError(f"--matcher {given!r}, but {table.where} was matched by {table.matcher!r}: leave out "
                         "--matcher (the table says its matcher) or give that matcher's table")
    return table.matcher


def _predictor_sha256(job: CalibrateJob | DeployJob, source: str) -> str | None:
    if source != PREDICTOR or job.predictor is None:
        return None
    from vpr_smr.eval.matching.ground_truth_files import file_sha256

    if not Path(job.predictor).is_file():
        raise ValueError(f"--predictor {job.predictor}: no such file")
    return file_sha256(job.predictor)


# --- the rules, checked (the commands' and the Python API's) -----------------------------------------------------


def calibrate(confidence: np.ndarray, correct: np.ndarray, precision: float = 0.9, risk: float = DEFAULT_RISK,
              rule: str = GUARANTEED, where: str = "the calibration split") -> Calibration:
    """``thresholds.calibrate`` after the checks of method §16's inputs: a target in (0, 1], a risk in (0, 1), a
    known rule, a split with a correct match, and for ``guaranteed`` a target below 1 and, where it abstains, at
    least ``smallest_calibration`` queries. ValueError naming the setting and the fix."""
    precision = thresholds.check_precision(precision, "--precision")
    risk = thresholds.check_risk(risk, "--risk")
    if rule not in RULES:
        raise ValueError(f"--rule {rule!r}: choose one of {', '.join(RULES)}")
    values = np.asarray(confidence, dtype=np.float64).ravel()
    labels = np.asarray(correct).ravel()
    if len(values) == 0:
        raise ValueError(f"{where} has no evaluated query: calibrate on a split with queries")
    if not np.asarray(labels, dtype=bool).any():
        raise ValueError(f"{where} has no correct sequence match among its {len(values)} queries: no threshold "
                         "reaches any precision there; calibrate on a split the method matches")
    if rule == GUARANTEED and precision == 1:
        raise ValueError("--precision 1 cannot be guaranteed from a finite calibration split (the bound is never "
                         "0): give a target below 1, or --rule empirical")
    found = thresholds.calibrate(values, labels, precision, rule, risk)
    if rule == GUARANTEED and found.abstains:
        # the size is what the search needs with distinct confidences; tied ones may let a smaller split through,
        # so only a split that abstains is refused by it
        needed = thresholds.smallest_calibration(precision, risk)
        if len(values) < needed:
            raise ValueError(f"--rule guaranteed needs at least {needed} calibration queries for precision "
                             f"{precision:g} at risk {risk:g} (with distinct confidences, every one correct); you "
                             f"gave {len(values)} and it sets no threshold: calibrate on a longer split, lower the "
                             "target or raise the risk")
    return found


@dataclass(frozen=True)
class Deployed(Record):
    """A calibration applied to a split: which queries it accepts (``accepted``, in query order) and, with the
    split's labels, the realised numbers (``thresholds.realise``), the outcome against the target and the
    segments (``thresholds.segments``); None without labels."""

    accepted: np.ndarray
    realised: Realised | None = None
    outcome: str | None = None
    segments: Segments | None = None


def deploy(confidence: np.ndarray, calibration: Calibration, correct: np.ndarray | None = None,
           segment: int = DEFAULT_SEGMENT, intervals: bool = True) -> Deployed:
    """``calibration`` on a split of ``confidence`` (``same_fraction`` needs these only), and with ``correct`` what
    it realises there. ValueError for an empty split, labels of another length or a segment below 1."""
    values = np.asarray(confidence, dtype=np.float64).ravel()
    if len(values) == 0:
        raise ValueError("the deployment split has no evaluated query: deploy on a split with queries")
    if segment < 1:
        raise ValueError(f"--segment {segment}: give the queries per segment, at least 1")
    mask = thresholds.accept(values, calibration)
    if correct is None:
        return Deployed(mask)
    labels = np.asarray(correct, dtype=bool).ravel()
    if len(labels) != len(values):
        raise ValueError(f"{len(values)} confidences but {len(labels)} labels: give one of each per query")
    realised = thresholds.realise(mask, labels, intervals)
    return Deployed(mask, realised, thresholds.outcome(realised, calibration.precision),
                    thresholds.segments(mask, labels, calibration.precision, segment))


# --- the stages ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Calibrated:
    """What ``calibrate`` wrote and printed: the threshold file, the calibration split's numbers at its threshold,
    and for ``guaranteed`` the fewest calibration queries it can use."""

    file: ThresholdFile
    on_calibration: Realised
    smallest: int | None


@dataclass(frozen=True)
class DeployedSplit(Record):
    """The ``deploy`` stage's JSON: the threshold file applied, the split, how many queries it accepts and, with
    labels, the realised numbers, the outcome and the segments."""

    thresholds: ThresholdFile
    split: str
    n_queries: int
    accepted: int
    labelled: bool
    realised: Realised | None = None
    outcome: str | None = None
    segments: Segments | None = None


def calibrate_main(job: CalibrateJob) -> Calibrated:
    """The ``calibrate`` stage: the threshold file of ``job`` written to ``job.out`` after every check."""
    out = check_suffix(job.out, JSON_SUFFIXES, "the threshold file (JSON)")
    thresholds.check_precision(job.precision, "--precision")
    thresholds.check_risk(job.risk, "--risk")
    missing = [option for option, value in (("--method NAME", job.method), ("--seq-len L", job.seq_len))
               if value is None]
    if job.source == PREDICTOR and job.predictor is None:
        missing.append("--predictor PATH (the predictor whose confidence it is)")
    if missing:
        raise ValueError(f"give {' and '.join(missing)}: the threshold file records them, so that deploy and the "
                         "live matcher refuse a confidence of another method, length or predictor")
    table = read_split(job, job.source, CALIBRATION_SPLIT, job.seq_len)
    if table.correct is None:
        raise ValueError(f"{table.where} has no labels (sequence_correct is empty): calibrate on a labelled split")
    found = calibrate(table.confidence, table.correct, job.precision, job.risk, job.rule, table.where)
    file = ThresholdFile.of(found, job.source, _input_matcher(job, table), table.split, table.confidence,
                            table.correct, job.method, job.seq_len, _predictor_sha256(job, job.source),
                            job.scorers.meta())
    on_calibration = thresholds.realise(thresholds.accept(table.confidence, found), table.correct, intervals=False)
    smallest = thresholds.smallest_calibration(job.precision, job.risk) if job.rule == GUARANTEED else None
    write_thresholds(out, file)
    return Calibrated(file, on_calibration, smallest)


def calibrate_text(job: CalibrateJob, result: Calibrated) -> str:
    """What ``calibrate`` prints: the threshold, the calibration split's numbers, and ``guaranteed``'s least size."""
    file, numbers = result.file, result.on_calibration
    lines = [f"calibrated on split {file.split} ({file.n_queries} queries): {file.described()}",
             _numbers("on the calibration split", numbers)]
    if file.rule == thresholds.SAME_FRACTION:
        lines.append(f"on another split: its most confident queries, {file.accepted} of every {file.n_queries} "
                     "(rounded up, ties at the cut included)")
    if result.smallest is not None:
        lines.append(f"guaranteed needs at least {result.smallest} calibration queries for precision "
                     f"{file.precision:g} at risk {file.risk:g}")
    return "\n".join(lines)


def _against(interval: Any, target: float) -> str:
    """What the precision's interval over the split's queries says of the target, beside the outcome (which is the
    split's own precision against it)."""
    if interval is None:
        return ""
    where = ("lies above" if interval.low >= target else "lies below" if interval.high < target else "includes")
    return f" (its interval {where} {target:g})"


def _numbers(what: str, numbers: Realised) -> str:
    def shown(value: float | None, interval: Any) -> str:
        if value is None:
            return "undefined (nothing accepted)"
        return f"{value:.4f}" + ("" if interval is None else f" [{interval.low:.4f}, {interval.high:.4f}]")

    return (f"{what}: precision {shown(numbers.precision, numbers.precision_ci)}, recall "
            f"{shown(numbers.recall, numbers.recall_ci)}, accepted {numbers.accepted} of {numbers.n_queries} "
            f"(fraction {numbers.accepted_fraction:.4f}, {numbers.wrong} wrong)")


def deploy_main(job: DeployJob) -> DeployedSplit:
    """The ``deploy`` stage: the threshold file of ``job`` applied to its split, checked against the input, written
    to ``job.out`` (and the accepted queries to ``job.accepted``)."""
    out = check_suffix(job.out, JSON_SUFFIXES, "what the threshold does on the split (JSON)")
    accepted_out = (None if job.accepted is None
                    else check_suffix(job.accepted, CSV_SUFFIXES, "the accepted queries (CSV)", "--accepted"))
    file = read_thresholds(job.thresholds)
    where = job.thresholds
    seq_len = job.seq_len if job.seq_len is not None else file.seq_len
    _where(job)
    if job.distances and seq_len is None:
        raise ValueError(f"--distances needs --seq-len L: the threshold file {where} does not record it")
    named = f"the threshold file {where}"
    check_same(file, "this input (--method, --seq-len, --r-window, --spread-k)", method=job.method, seq_len=seq_len,
               scorers=job.scorers.meta(), name=named)
    table = read_split(job, file.source, None, seq_len)
    check_same(file, table.where, matcher=_input_matcher(job, table), name=named)  # the source: the file's column
    mine, theirs = file.predictor_sha256, _predictor_sha256(job, file.source)
    if mine is not None and theirs is not None and mine != theirs:
        raise ValueError(f"the threshold file {where} was calibrated with the predictor of SHA-256 {mine[:12]}..., "
                         f"--predictor {job.predictor} has {theirs[:12]}...: calibrate again with this predictor")
    found = deploy(table.confidence, file.calibration, table.correct, job.segment)
    result = DeployedSplit(file, table.split, len(table.confidence), int(found.accepted.sum()),
                           table.correct is not None, found.realised, found.outcome, found.segments)
    if accepted_out is not None:
        _write_accepted(accepted_out, table, found.accepted)
    write_json(out, encode(result))
    return result


def _write_accepted(path: Path, table: SplitTable, accepted: np.ndarray) -> None:
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(("query", "sequence_match", "confidence", "accepted"))
        writer.writerows(_accepted_rows(table, accepted))


def _accepted_rows(table: SplitTable, accepted: np.ndarray) -> Iterable[Sequence[str]]:
    for query, match, value, taken in zip(table.query, table.sequence_match, table.confidence, accepted,
                                          strict=True):
        yield str(int(query)), str(int(match)), repr(float(value)), str(int(taken))


def deploy_text(job: DeployJob, result: DeployedSplit) -> str:
    """What ``deploy`` prints: the threshold applied, and with labels the realised numbers and the segments."""
    file = result.thresholds
    lines = [f"deployed {file.described()} on split {result.split} ({result.n_queries} queries): accepted "
             f"{result.accepted}"]
    if result.realised is None:
        lines.append(f"split {result.split} has no labels: the accepted matches only (no precision to compare)")
        return "\n".join(lines)
    lines.append(_numbers("realised", result.realised))
    lines.append(f"target precision {file.precision:g}: {result.outcome}"
                 + _against(result.realised.precision_ci, file.precision))
    if result.segments is not None:
        seg = result.segments
        lines.append(f"segments of {seg.size} queries: {seg.n_segments}, of which {seg.with_acceptance} accept a "
                     f"match and {seg.violated} of those fall below precision {file.precision:g}")
    return "\n".join(lines)

