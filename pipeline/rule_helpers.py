"""Small functions the Snakemake rules use to name files (kept out of the rule files, as Snakemake's lint asks)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any


def features_path(out: str, dataset: str, method: str, seq_len: int | str, split: str) -> str:
    return f"{out}/features/{dataset}/{method}/L{seq_len}/{split}.h5"


def split_features(out: str, methods: Sequence[str], split: str) -> Callable[[Any], list[str]]:
    """Every method's features of one split, in the configuration's order (the pooled training order)."""
    return lambda wc: [features_path(out, wc.dataset, method, wc.seq_len, split) for method in methods]


def seed_models(conf: dict[str, Any], stem: str) -> list[str]:
    """The predictor files of every seed: ``<stem>.h5`` for seed 0 (the authors' recipe), then ``.seed<s>.h5``."""
    return [f"{stem}.h5"] + [f"{stem}.seed{seed}.h5" for seed in range(1, conf["seeds"])]


def extraction_options(conf: dict[str, Any]) -> str:
    options = {"--batch-size": conf["extraction"]["batch_size"], "--num-workers": conf["extraction"]["num_workers"]}
    return " ".join(f"{key} {value}" for key, value in options.items() if value is not None)


def table_figures(conf: dict[str, Any]) -> list[str]:
    """The figures of `vpr-smr tables`, named by dataset, sequence length and mode."""
    out = f"{conf['output']}/{conf['run']}/figures"
    names = []
    for dataset in conf["datasets"]:
        for seq_len in conf["seq_lens"]:
            names += [f"pr_{dataset}_L{seq_len}_{mode}.png" for mode in conf["modes"]]
            names += [f"trust_{dataset}_L{seq_len}.png", f"confusion_{dataset}_L{seq_len}.png"]
    return [f"{out}/{name}" for name in names]
