"""``report.html``: one self-contained page with every table and figure, the configuration and the provenance.

Figures are embedded as base64 PNG data URIs and the style sheet is inline, so the page needs no network and no
file beside it: it can be mailed or archived on its own.
"""

from __future__ import annotations

import base64
import csv
import html
import json
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from vpr_smr.core.citation import how_to_cite
from vpr_smr.core.io import atomic_path, package_version, read_provenance

STYLE = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1400px; color: #222; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; margin-top: 2em; }
table { border-collapse: collapse; font-size: 0.85em; margin: 0.5em 0 1.5em; }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: right; }
th { background: #f0f0f0; } td.text { text-align: left; }
pre { background: #f6f6f6; padding: 0.8em; overflow-x: auto; font-size: 0.85em; }
figure { margin: 1em 0 2em; } img { max-width: 100%; height: auto; }
figcaption { font-size: 0.9em; color: #555; } nav li { margin: 0.15em 0; }
div.wide { overflow-x: auto; } p.warning { color: #a00; border: 2px solid #a00; padding: 0.5em; }
"""
DESCRIPTOR_KEYS = ("dataset", "method", "checkpoint_sha256", "frames_sha256", "vpr_smr_version")
UNDEFINED = "n/a"  # a reduction whose baseline AOC is 0: JSON null, an empty CSV cell


def is_reduction(column: str) -> bool:
    """A column of AOC reductions, undefined where the AOC reduced is 0."""
    return "reduction_pct" in column


def _cell(value: str, column: str = "") -> str:
    if value == "" and is_reduction(column):
        return f'<td class="text">{UNDEFINED}</td>'
    try:
        number = float(value)
    except ValueError:
        return f'<td class="text">{html.escape(value)}</td>'
    text = value if value.lstrip("-").isdigit() else f"{number:.4f}"
    return f"<td>{html.escape(text)}</td>"


def csv_table(path: Path | str) -> str:
    """An HTML table of a CSV file (header row first), floats to 4 decimals."""
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    if not rows:
        return "<p>(empty)</p>"
    head = "".join(f"<th>{html.escape(c)}</th>" for c in rows[0])
    body = "\n".join("<tr>" + "".join(_cell(c, name) for c, name in zip(row, rows[0], strict=False)) + "</tr>"
                     for row in rows[1:])
    return f'<div class="wide"><table>\n<tr>{head}</tr>\n{body}\n</table></div>'


def image_uri(path: Path | str) -> str:
    return "data:image/png;base64," + base64.b64encode(Path(path).read_bytes()).decode("ascii")


def _dict_table(rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> str:
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = "\n".join("<tr>" + "".join(f'<td class="text">{html.escape(str(r.get(c, "")))}</td>' for c in columns)
                     + "</tr>" for r in rows)
    return f"<table>\n<tr>{head}</tr>\n{body}\n</table>"


def provenance_rows(provenance: dict[str, Any] | None, descriptor_paths: Sequence[Path | str] = ()
                    ) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The run's provenance (the package version added when missing) and, per descriptor file, its dataset,
    method, checkpoint and frame-list SHA-256 (read from the file's HDF5 attributes)."""
    general = {"vpr_smr_version": package_version(), **(provenance or {})}
    files = []
    for path in descriptor_paths:
        attrs = read_provenance(path)
        files.append({"file": str(path), **{k: attrs.get(k, "") for k in DESCRIPTOR_KEYS}})
    return general, files


def _overlap_warnings(datasets: dict[str, dict[str, Any]] | None) -> list[str]:
    return [f'<p class="warning"><strong>Warning, {html.escape(name)}: splits share frames '
            f"(allow_split_overlap: true): {html.escape('; '.join(info['overlaps']))}.</strong> Its numbers are "
            "measured partly on frames the predictor was trained or validated on.</p>"
            for name, info in (datasets or {}).items() if info.get("overlaps")]


def _dataset_rows(datasets: dict[str, dict[str, Any]] | None) -> list[str]:
    """The datasets: traverses, frames, tolerance, every split with its size, and how the frames were paired."""
    if not datasets:
        return []
    rows = [{
        "dataset": name, "reference": info.get("reference", ""), "query": info.get("query", ""),
        "frames": info.get("n_frames", ""), "tolerance": info.get("tolerance", ""),
        "splits": ", ".join(f"{split} [{lo}, {hi}): {hi - lo} frames" for split, (lo, hi) in info["splits"].items()),
        "paired": info.get("pairing", ""), "splits overlap": "; ".join(info.get("overlaps", [])) or "no",
        "frame lists SHA-256": info.get("frames_sha256", ""),
    } for name, info in datasets.items()]
    return ["<h3>Datasets</h3>", _dict_table(rows, list(rows[0]))]


def _anchor(text: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in text.lower()).strip("-")


def render(
    tables: Sequence[tuple[str, Path | str]],
    figures: Sequence[tuple[str, Path | str]],
    config: str | dict[str, Any] | None = None,
    provenance: dict[str, Any] | None = None,
    descriptor_paths: Sequence[Path | str] = (),
    title: str = "vpr-smr report",
    datasets: dict[str, dict[str, Any]] | None = None,
) -> str:
    """The page as a string: ``tables`` are (title, CSV path), ``figures`` (caption, PNG path); ``datasets`` as
    ``report.main`` takes them."""
    general, files = provenance_rows(provenance, descriptor_paths)
    if isinstance(config, dict):
        import yaml

        config = yaml.safe_dump(config, sort_keys=False)
    sections = [("Provenance", "")] + [(name, "") for name, _ in tables] + [("Figures", ""), ("Configuration", "")]
    nav = "".join(f'<li><a href="#{_anchor(name)}">{html.escape(name)}</a></li>' for name, _ in sections)
    parts = [
        "<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
        f"<title>{html.escape(title)}</title>", f"<style>{STYLE}</style>", "</head>", "<body>",
        f"<h1>{html.escape(title)}</h1>",
        f"<p>Generated {datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')}.</p>",
        f"<nav><ul>{nav}</ul></nav>",
        *_overlap_warnings(datasets),
        f'<h2 id="{_anchor("Provenance")}">Provenance</h2>',
        f'<p class="cite"><strong>How to cite:</strong> {html.escape(how_to_cite(str(general["vpr_smr_version"])))}'
        "</p>",
        *_dataset_rows(datasets),
        _dict_table([{"key": k, "value": v if isinstance(v, str) else json.dumps(v, sort_keys=True)}
                     for k, v in general.items()], ("key", "value")),
    ]
    if files:
        parts.append(_dict_table(files, ("file", *DESCRIPTOR_KEYS)))
    for name, path in tables:
        parts += [f'<h2 id="{_anchor(name)}">{html.escape(name)}</h2>',
                  f"<p>{html.escape(Path(path).name)} (also as .md and .tex beside it)</p>", csv_table(path)]
    parts.append(f'<h2 id="{_anchor("Figures")}">Figures</h2>')
    for caption, path in figures:
        parts += ["<figure>", f'<img src="{image_uri(path)}" alt="{html.escape(caption)}">',
                  f"<figcaption>{html.escape(caption)} ({html.escape(Path(path).name)})</figcaption>", "</figure>"]
    parts += [f'<h2 id="{_anchor("Configuration")}">Configuration</h2>',
              f"<pre>{html.escape(config or '(not given)')}</pre>", "</body>", "</html>"]
    return "\n".join(parts) + "\n"


def main(
    out: Path | str,
    tables: Sequence[tuple[str, Path | str]],
    figures: Sequence[tuple[str, Path | str]],
    config: str | dict[str, Any] | None = None,
    provenance: dict[str, Any] | None = None,
    descriptor_paths: Sequence[Path | str] = (),
    title: str = "vpr-smr report",
    datasets: dict[str, dict[str, Any]] | None = None,
) -> Path:
    """Write the page to ``out`` (temporary name, then rename) and return its path."""
    text = render(tables, figures, config, provenance, descriptor_paths, title, datasets)
    out = Path(out)
    with atomic_path(out) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return out
