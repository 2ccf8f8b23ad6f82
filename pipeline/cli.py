"""The ``vpr-smr`` command: one subcommand per stage, each a thin wrapper of a ``main`` function."""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path
from typing import Any

from .config import ConfigError, load_config

log = logging.getLogger("vpr_smr")


def _dataset(conf: dict[str, Any], name: str):
    from ..datasets import load_dataset

    if name not in conf["datasets"]:
        raise ConfigError(f"dataset {name!r} is not in the configuration; it has {', '.join(conf['datasets'])}")
    return load_dataset(name, conf["datasets"][name])


def _method(conf: dict[str, Any], name: str) -> dict[str, Any]:
    if name not in conf["methods"]:
        raise ConfigError(f"method {name!r} is not in the configuration; it has {', '.join(conf['methods'])}")
    return conf["methods"][name]


def cmd_descriptors(args: argparse.Namespace) -> None:
    from ..descriptors import extract

    conf = load_config(args.config)
    pair = _dataset(conf, args.dataset)
    extraction = conf["extraction"]
    extract.main(pair, args.method, _method(conf, args.method), args.out,
                 batch_size=extraction["batch_size"], num_workers=extraction["num_workers"])


def cmd_distances(args: argparse.Namespace) -> None:
    import h5py

    from ..eval.distances import distance_matrix
    from ..eval.io import write_distance_matrix

    conf = load_config(args.config)
    pair = _dataset(conf, args.dataset)
    lo, hi = pair.split_range(args.split)
    with h5py.File(args.descriptors, "r") as f:
        metric = f.attrs["distance"]
        reference, query = f["reference"][lo:hi], f["query"][lo:hi]
        provenance = {k: f.attrs[k] for k in ("dataset", "method", "checkpoint_sha256", "frames_sha256")}
    matrix = distance_matrix(reference, query, metric)
    write_distance_matrix(args.out, matrix, {**provenance, "split": args.split, "split_range": [lo, hi],
                                             "metric": metric})


def cmd_attributes(args: argparse.Namespace) -> None:
    import numpy as np

    from ..eval.attributes import ATTRIBUTE_NAMES, query_features
    from ..eval.io import atomic_path, read_distance_matrix, read_provenance, write_features

    matrix = read_distance_matrix(args.distances)
    if not np.issubdtype(matrix.dtype, np.number):  # shape and values are checked by query_features
        raise ValueError(f"{args.distances}: expected a numeric matrix (references x queries), got {matrix.dtype}")
    start = time.perf_counter()
    try:
        features = query_features(matrix, args.seq_len, args.tolerance)
    except ValueError as error:
        raise ValueError(f"{args.distances}: {error}") from None
    seconds = time.perf_counter() - start
    out = Path(args.out)
    if out.suffix == ".csv":
        table = np.column_stack([features.queries, features.attributes[:, 0, :], features.labels])
        header = ",".join(("query", *ATTRIBUTE_NAMES, "label"))
        with atomic_path(out) as tmp:
            np.savetxt(tmp, table, delimiter=",", header=header, comments="", fmt=["%d", *["%.9g"] * 4, "%d"])
    else:
        provenance = read_provenance(args.distances) if Path(args.distances).suffix != ".npy" else {}
        provenance = {k: v for k, v in provenance.items() if k != "vpr_smr_version"}
        write_features(out, features, {**provenance, "seq_len": args.seq_len, "tolerance": args.tolerance,
                                       "attributes_seconds": seconds})
    log.info("%d queries, %.1f µs per query", len(features.queries), 1e6 * seconds / max(len(features.queries), 1))


def cmd_train(args: argparse.Namespace) -> None:
    from ..eval import train

    conf = load_config(args.config)
    report = train.main(args.train, args.out, conf["predictor"], val=args.val or (), test=args.test or (),
                        meta={"dataset": args.dataset, "seq_len": args.seq_len})
    log.info("predictor macro F1: cv %.3f, val %s, test %s", report["f1_cv"], report.get("f1_val"),
             report.get("f1_test"))


def cmd_evaluate(args: argparse.Namespace) -> None:
    from ..eval import evaluate

    conf = load_config(args.config)
    paths = dict(item.split("=", 1) for item in args.features)
    evaluate.main(paths, args.predictor, args.out, tuple(conf["modes"]), tuple(conf["trust_levels"]),
                  meta={"dataset": args.dataset, "method": args.method, "seq_len": args.seq_len})


def cmd_tables(args: argparse.Namespace) -> None:
    from ..eval import report

    out = report.main(args.evaluations, args.predictors, args.out, args.split)
    print(f"tables:  {out['tables']}\nfigures: {out['figures']}")


def _options(items: list[str] | None) -> dict[str, Any]:
    """``key=value`` settings; values parsed as YAML (numbers, lists, null) so they match the config file."""
    import yaml

    options = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--option {item!r} is not of the form key=value")
        options[key] = yaml.safe_load(value)
    return options


def cmd_checkpoint_check(args: argparse.Namespace) -> int:
    import numpy as np

    from ..descriptors.base import CheckpointError
    from ..descriptors.extract import build_backend

    conf = {"backend": args.method, "checkpoint": args.file, **_options(args.option)}
    try:
        backend, digest = build_backend(args.method, conf)
        size = backend.describe(np.full((224, 224, 3), 127, dtype=np.uint8)).shape[0]
    except CheckpointError as error:
        print(f"NOT OK: {error}", file=sys.stderr)
        return 1
    print(f"OK: {args.file} loads into backend {args.method!r} (strict); descriptor size {size}; sha256 {digest}")
    return 0


def cmd_convert_checkpoint(args: argparse.Namespace) -> int:
    from ..descriptors.convert import CONVERTERS

    if args.method not in CONVERTERS:
        raise ValueError(f"no conversion for {args.method!r}; available: {', '.join(CONVERTERS)}")
    out = CONVERTERS[args.method](args.input, args.output)
    print(f"wrote {out}: load it with `checkpoint: {out}` in the method's settings")
    return 0


def cmd_dataset_check(args: argparse.Namespace) -> int:
    from ..datasets import check

    return check.main(args.name, args.root, **_options(args.option))


def cmd_run(args: argparse.Namespace) -> int:
    from . import workflow

    return workflow.run(args.config, cores=args.cores, dry_run=args.dry_run, extra=args.snakemake_args)


def _required(parser: argparse.ArgumentParser, *options: str) -> None:
    for option in options:
        parser.add_argument(option, required=True)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="vpr-smr", description=__doc__)
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("run", help="run the whole workflow of a configuration with Snakemake")
    p.add_argument("config")
    p.add_argument("--cores", type=int, default=2)
    p.add_argument("-n", "--dry-run", action="store_true")
    p.add_argument("snakemake_args", nargs=argparse.REMAINDER, help="passed on to snakemake after --")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("checkpoint", help="checkpoint tools")
    checkpoint_sub = p.add_subparsers(dest="checkpoint_command", required=True)
    c = checkpoint_sub.add_parser("check", help="load a downloaded checkpoint exactly as the pipeline would")
    c.add_argument("method", help="backend name, e.g. netvlad, cosplace, salad")
    c.add_argument("file")
    c.add_argument("--option", action="append", metavar="KEY=VALUE", help="a backend setting (repeatable)")
    c.set_defaults(func=cmd_checkpoint_check)

    p = sub.add_parser("convert-checkpoint", help="turn an official pickle into a plain tensor file (apgem)")
    p.add_argument("method")
    p.add_argument("input")
    p.add_argument("output")
    p.set_defaults(func=cmd_convert_checkpoint)

    p = sub.add_parser("dataset", help="dataset tools")
    dataset_sub = p.add_subparsers(dest="dataset_command", required=True)
    c = dataset_sub.add_parser("check", help="verify a dataset on disk before a long run")
    c.add_argument("name", help="loader name: nordland, robotcar, sfu_mountain, nordland_sample, folders")
    c.add_argument("--root", help="the dataset's folder")
    c.add_argument("--option", action="append", metavar="KEY=VALUE", help="a loader setting (repeatable)")
    c.set_defaults(func=cmd_dataset_check)

    p = sub.add_parser("descriptors", help="compute a method's descriptors of a dataset (HDF5)")
    _required(p, "--config", "--dataset", "--method", "--out")
    p.set_defaults(func=cmd_descriptors)

    p = sub.add_parser("distances", help="reference x query distance matrix of one split (HDF5)")
    _required(p, "--config", "--dataset", "--split", "--descriptors", "--out")
    p.set_defaults(func=cmd_distances)

    p = sub.add_parser("attributes", help="sequence matching, SMR attributes and labels of a distance matrix")
    p.add_argument("--distances", required=True, help="our .h5 or a references x queries .npy")
    p.add_argument("--seq-len", type=int, required=True)
    p.add_argument("--tolerance", type=int, default=2)
    p.add_argument("--out", required=True, help=".csv (query,A1,A2,A3,A4,label) or .h5 (everything)")
    p.set_defaults(func=cmd_attributes)

    p = sub.add_parser("train", help="train the predictor on the pooled train features of every method")
    _required(p, "--config", "--dataset")
    p.add_argument("--seq-len", type=int, required=True)
    p.add_argument("--train", nargs="+", required=True)
    p.add_argument("--val", nargs="*")
    p.add_argument("--test", nargs="*")
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_train)

    p = sub.add_parser("evaluate", help="match removal and precision-recall of one method")
    _required(p, "--config", "--dataset", "--method")
    p.add_argument("--seq-len", type=int, required=True)
    p.add_argument("--features", nargs="+", required=True, metavar="SPLIT=PATH")
    _required(p, "--predictor", "--out")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("tables", help="paper-style tables and figures")
    p.add_argument("--evaluations", nargs="+", required=True)
    p.add_argument("--predictors", nargs="+", required=True)
    p.add_argument("--split", default="test")
    p.add_argument("--out", required=True, help="the run folder: tables/ and figures/ go inside")
    p.set_defaults(func=cmd_tables)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="%(asctime)s %(name)s %(levelname)s: %(message)s")
    try:
        status = args.func(args)
    except (ConfigError, ValueError, FileNotFoundError, OSError) as error:
        print(f"vpr-smr {args.command}: error: {error}", file=sys.stderr)
        return 2
    return int(status or 0)


if __name__ == "__main__":
    sys.exit(main())
