"""Paper-style tables and figures from the evaluation and predictor JSON files (SPEC section 10)."""

from __future__ import annotations

import csv
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .io import atomic_path

TABLE1_COLUMNS = (
    "dataset", "method", "seq_len", "mode", "recall_at_1_single", "recall_at_1_sequence", "max_recall",
    "aoc_vpr_sm", "aoc_vpr_sm_pred", "reduction_pct",
)
PREDICTOR_COLUMNS = ("dataset", "seq_len", "n_train", "f1_cv", "f1_val", "f1_test")


def table1_rows(evaluations: Sequence[dict[str, Any]], split: str = "test") -> list[dict[str, Any]]:
    rows = []
    for evaluation in evaluations:
        meta, result = evaluation["meta"], evaluation["splits"][split]
        for mode, numbers in result["modes"].items():
            rows.append({
                "dataset": meta["dataset"], "method": meta["method"], "seq_len": meta["seq_len"], "mode": mode,
                "recall_at_1_single": result["recall_at_1_single"],
                "recall_at_1_sequence": result["recall_at_1_sequence"],
                **{k: numbers[k] for k in ("max_recall", "aoc_vpr_sm", "aoc_vpr_sm_pred", "reduction_pct")},
            })
    return sorted(rows, key=lambda r: (r["mode"], r["seq_len"], r["dataset"], r["method"]))


def _groups(rows: list[dict[str, Any]]) -> dict[tuple[str, int], dict[str, list[dict[str, Any]]]]:
    """(mode, seq_len) -> dataset -> rows (one per method, sorted by method)."""
    groups: dict[tuple[str, int], dict[str, list[dict[str, Any]]]] = {}
    for row in rows:
        groups.setdefault((row["mode"], row["seq_len"]), {}).setdefault(row["dataset"], []).append(row)
    return groups


def _summary(rows: list[dict[str, Any]]) -> tuple[list[list[float]], int]:
    """Per-method values of the three table rows, with the mean appended; and the number of methods improved."""
    values = [[r["aoc_vpr_sm"] for r in rows], [r["aoc_vpr_sm_pred"] for r in rows], [r["reduction_pct"] for r in rows]]
    return [v + [float(np.mean(v))] for v in values], sum(r["reduction_pct"] > 0 for r in rows)


ROW_NAMES = ("VPR+SM", "VPR+SM+Pred", "Reduction (%)")


def table1_markdown(rows: list[dict[str, Any]]) -> str:
    out = ["# Table I: area over the precision-recall curve at max recall (test split)", ""]
    for (mode, seq_len), datasets in sorted(_groups(rows).items()):
        methods = [r["method"] for r in next(iter(datasets.values()))]
        out += [f"## {mode} mode, sequence length {seq_len}", ""]
        out.append("| dataset | | " + " | ".join(methods) + " | Mean | Improved |")
        out.append("|---|---|" + "---|" * (len(methods) + 2))
        for dataset, dataset_rows in datasets.items():
            summary, improved = _summary(dataset_rows)
            for i, (name, values) in enumerate(zip(ROW_NAMES, summary, strict=True)):
                fmt = "{:.2f}" if i == 2 else "{:.4f}"
                last = f"{improved} / {len(dataset_rows)}" if i == 2 else ""
                label = dataset if i == 0 else ""
                out.append(f"| {label} | {name} | " + " | ".join(fmt.format(v) for v in values) + f" | {last} |")
        out.append("")
    return "\n".join(out)


def _tex_escape(text: str) -> str:
    return text.replace("_", r"\_").replace("%", r"\%")


def table1_latex(rows: list[dict[str, Any]]) -> str:
    out = []
    for (mode, seq_len), datasets in sorted(_groups(rows).items()):
        methods = [r["method"] for r in next(iter(datasets.values()))]
        out += [
            f"% {mode} mode, sequence length {seq_len}",
            r"\begin{tabular}{l|c|" + "c|" * (len(methods) + 1) + "c}",
            r"\multicolumn{2}{c|}{} & " + " & ".join(_tex_escape(m) for m in methods) + r" & Mean & Improved\\",
            r"\hline",
        ]
        for dataset, dataset_rows in datasets.items():
            summary, improved = _summary(dataset_rows)
            for i, (name, values) in enumerate(zip(ROW_NAMES, summary, strict=True)):
                if i == 2:
                    cells = [rf"\textcolor{{{'green' if v > 0 else 'red' if v < 0 else 'black'}}}{{{v:.2f}}}"
                             for v in values]
                    last = f"{improved} / {len(dataset_rows)}"
                else:
                    cells, last = [f"{v:.4f}" for v in values], ""
                label = _tex_escape(dataset) if i == 0 else ""
                out.append(f"{label} & {_tex_escape(name)} & " + " & ".join(cells) + f" & {last}" + r"\\")
            out.append(r"\hline")
        out += [r"\end{tabular}", ""]
    return "\n".join(out)


def _write_text(path: Path, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def _write_csv(path: Path, columns: Sequence[str], rows: list[dict[str, Any]]) -> None:
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(columns), extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def figures(evaluations: Sequence[dict[str, Any]], predictors: Sequence[dict[str, Any]], out_dir: Path,
            split: str = "test") -> list[Path]:
    """PR curves per dataset (methods side by side), trust-level curves and confusion matrices."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    by_key: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for evaluation in evaluations:
        by_key.setdefault((evaluation["meta"]["dataset"], evaluation["meta"]["seq_len"]), []).append(evaluation)
    for (dataset, seq_len), items in sorted(by_key.items()):
        items = sorted(items, key=lambda e: e["meta"]["method"])
        for mode in items[0]["splits"][split]["modes"]:
            fig, axes = plt.subplots(1, len(items), figsize=(3.2 * len(items), 3.2), squeeze=False)
            for ax, evaluation in zip(axes[0], items, strict=True):
                numbers = evaluation["splits"][split]["modes"][mode]
                for key, label, style in (("curve_vpr_sm", "VPR+SM", "-"), ("curve_vpr_sm_pred", "VPR+SM+Pred", "-")):
                    ax.plot(numbers[key]["recall"], numbers[key]["precision"], style, label=label)
                ax.axvline(numbers["max_recall"], color="grey", lw=0.5, ls=":")
                ax.set(title=f"{evaluation['meta']['method']}\nAOC {numbers['aoc_vpr_sm']:.3f} -> "
                             f"{numbers['aoc_vpr_sm_pred']:.3f}", xlabel="recall", ylim=(0, 1.02), xlim=(0, 1))
            axes[0][0].set_ylabel("precision")
            axes[0][-1].legend(loc="upper right", fontsize=8)
            fig.suptitle(f"{dataset}, L={seq_len}, {mode} mode ({split})")
            fig.tight_layout()
            written.append(_save(fig, out_dir / f"pr_{dataset}_L{seq_len}_{mode}.png"))
        modes = items[0]["splits"][split]["modes"]
        trust_mode = "paper" if "paper" in modes else next(iter(modes))  # the paper's figure is in paper mode
        fig, axes = plt.subplots(1, len(items), figsize=(3.2 * len(items), 3.2), squeeze=False)
        for ax, evaluation in zip(axes[0], items, strict=True):
            for level, trust_curve in evaluation["splits"][split]["modes"][trust_mode]["trust"].items():
                ax.plot(trust_curve["recall"], trust_curve["precision"], label=f"trust >= {level}")
            ax.set(title=evaluation["meta"]["method"], xlabel="recall", ylim=(0, 1.02), xlim=(0, 1))
        axes[0][0].set_ylabel("precision")
        axes[0][-1].legend(loc="upper right", fontsize=7)
        fig.suptitle(f"{dataset}, L={seq_len}: predictor trust levels ({trust_mode} mode, {split})")
        fig.tight_layout()
        written.append(_save(fig, out_dir / f"trust_{dataset}_L{seq_len}.png"))
        matrix = np.sum([np.array(e["splits"][split]["confusion_matrix"]) for e in items], axis=0)
        fig, ax = plt.subplots(figsize=(3.6, 3.2))
        ax.imshow(matrix, cmap="Blues")
        for (i, j), value in np.ndenumerate(matrix):
            ax.text(j, i, str(value), ha="center", va="center", fontsize=8)
        ax.set(xlabel="predicted", ylabel="true", xticks=range(4), yticks=range(4),
               title=f"{dataset}, L={seq_len}: all methods ({split})")
        fig.tight_layout()
        written.append(_save(fig, out_dir / f"confusion_{dataset}_L{seq_len}.png"))
    return written


def _save(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path


def main(evaluation_paths: Sequence[Path | str], predictor_paths: Sequence[Path | str], out_dir: Path | str,
         split: str = "test") -> dict[str, Path]:
    """Write ``tables/table1.{csv,md,tex}``, ``tables/predictor.csv`` and ``figures/*.png`` under ``out_dir``."""
    out_dir = Path(out_dir)
    tables, figure_dir = out_dir / "tables", out_dir / "figures"
    tables.mkdir(parents=True, exist_ok=True)
    evaluations = [json.loads(Path(p).read_text()) for p in evaluation_paths]
    predictors = [json.loads(Path(p).read_text()) for p in predictor_paths]
    rows = table1_rows(evaluations, split)
    _write_csv(tables / "table1.csv", TABLE1_COLUMNS, rows)
    _write_text(tables / "table1.md", table1_markdown(rows))
    _write_text(tables / "table1.tex", table1_latex(rows))
    predictor_rows = sorted(({**p, **p["meta"]} for p in predictors), key=lambda r: (r["dataset"], r["seq_len"]))
    _write_csv(tables / "predictor.csv", PREDICTOR_COLUMNS, predictor_rows)
    figures(evaluations, predictors, figure_dir, split)
    return {"tables": tables, "figures": figure_dir}
