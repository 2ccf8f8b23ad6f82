"""The ``vpr-smr`` command: one subcommand per stage, each a thin wrapper of a ``main`` function."""

from __future__ import annotations

import argparse
import gc
import logging
import signal
import sys
from typing import Any

from vpr_smr.core.io import package_version
from vpr_smr.eval.matching.matchers import DEFAULT_MATCHER
from vpr_smr.pipeline.config import ConfigError, load_config
from vpr_smr.pipeline.console import LOG_FORMAT
from vpr_smr.pipeline.experiment import plugin_stages
from vpr_smr.pipeline.options import matcher_of
from vpr_smr.pipeline.stage import JOB, install
from vpr_smr.pipeline.stages import COMMAND_GROUPS, STAGES

log = logging.getLogger("vpr_smr")


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

    from vpr_smr.descriptors.base import CheckpointError
    from vpr_smr.descriptors.extract import build_backend

    conf = {"backend": args.method, "checkpoint": args.file, **_options(args.option)}
    try:
        backend, digest = build_backend(args.method, conf)
        size = backend.describe(np.full((224, 224, 3), 127, dtype=np.uint8)).shape[0]
    except CheckpointError as error:
        print(f"NOT OK: {error}", file=sys.stderr)
        return 1
    print(f"OK: {args.file} loads into backend {args.method!r} (strict); descriptor size {size}; sha256 {digest}")
    return 0


def cmd_backends(args: argparse.Namespace) -> int:
    from vpr_smr.descriptors.catalogue import backend_facts, format_backends

    print(format_backends(backend_facts()))
    return 0


def cmd_matchers(args: argparse.Namespace) -> int:
    from vpr_smr.pipeline.options import matcher_catalogue

    print(matcher_catalogue())
    return 0


def cmd_convert_checkpoint(args: argparse.Namespace) -> int:
    from vpr_smr.descriptors.convert import CONVERTERS, no_conversion

    if args.method not in CONVERTERS:
        raise ValueError(no_conversion(args.method))
    out = CONVERTERS[args.method](args.input, args.output)
    print(f"wrote {out}: load it with `checkpoint: {out}` in the method's settings")
    return 0


def _frame_range(text: str, option: str) -> list[int]:
    """``LO:HI`` -> ``[LO, HI]`` (frames LO .. HI-1), as the configuration writes a range."""
    lo, sep, hi = text.partition(":")
    if not (sep and lo.strip().isdigit() and hi.strip().isdigit()):
        raise ValueError(f"{option}: {text!r} is not a frame range LO:HI (frames LO to HI-1), e.g. 0:100")
    return [int(lo), int(hi)]


def _splits(items: list[str]) -> dict[str, Any]:
    """``["train=0:40", "val=40:70"]`` -> ``{"train": [0, 40], "val": [40, 70]}``; ``test=0:90/40:70`` gives the
    reference and the query range apart: ``{"test": {"reference": [0, 90], "query": [40, 70]}}``."""
    splits: dict[str, Any] = {}
    for item in items:
        name, sep, frames = item.partition("=")
        if not sep or not name:
            raise ValueError(f"--splits {item!r} is not NAME=LO:HI, e.g. --splits train=0:40 val=40:70 test=70:111")
        reference, slash, query = frames.partition("/")
        splits[name] = _frame_range(frames, f"--splits {name}") if not slash else {
            "reference": _frame_range(reference, f"--splits {name} (references)"),
            "query": _frame_range(query, f"--splits {name} (queries)")}
    return splits


DATASET_OPTIONS = ("root", "reference", "query", "reference_list", "query_list", "pairing", "tolerance",
                   "reference_positions", "query_positions", "positions", "radius")


def _check_ground_truth(name: str, pair: Any) -> tuple[list[str], list[str]]:
    """``dataset check``'s check of a ground-truth file: the one ``vpr-smr run`` makes before its first job, its notes
    over every split of the pair."""
    from vpr_smr.pipeline.plan import ground_truth_problems

    problems: list[str] = []
    notes: list[str] = []
    ground_truth_problems(name, pair, list(pair.splits), problems, notes)
    return problems, notes


def cmd_dataset_check(args: argparse.Namespace) -> int:
    from vpr_smr.datasets import check

    given = {key: getattr(args, key) for key in DATASET_OPTIONS if getattr(args, key) is not None}
    if args.frames:
        given["frames"] = _frame_range(args.frames, "--frames")
    if args.splits:
        given["splits"] = _splits(args.splits)
    given.update(_options(args.option))
    if args.config:
        if args.name or given:
            raise ConfigError("give either --config (and --dataset) or a loader with its options, not both")
        datasets = load_config(args.config).datasets
        name = args.dataset or (next(iter(datasets)) if len(datasets) == 1 else None)
        if name is None or name not in datasets:
            raise ConfigError(f"{args.config}: give --dataset, one of {', '.join(datasets)}" if name is None else
                              f"{args.config}: datasets has no {name!r}; it has {', '.join(datasets)}")
        return check.main(datasets[name].to_json(), name=name, decode=args.decode,
                          check_ground_truth=_check_ground_truth, source=str(args.config))
    if not args.name:
        raise ConfigError("give a loader and its options (vpr-smr dataset check folders --reference DIR --query DIR"
                          " ...), or a configuration (vpr-smr dataset check --config my.yaml --dataset NAME)")
    return check.main({"loader": args.name, **given}, decode=args.decode, check_ground_truth=_check_ground_truth)


def cmd_run(args: argparse.Namespace) -> int:
    from vpr_smr.pipeline import workflow

    return workflow.run(args.config, cores=args.cores, dry_run=args.dry_run, extra=args.snakemake_args,
                        overrides=args.set, profile=args.profile, verbose=args.snakemake_output or args.verbose)


# The top-level help: plain text for users, in the order they run the commands (line breaks kept).
DESCRIPTION = """\
From the images of two traverses of a route (a reference and a query drive) to the tables, figures and report
of sequence-matching receptiveness (SMR) in visual place recognition, offline.

The usual order:
  1. check your data: every image found and decoded, the frames paired and split
       vpr-smr dataset check folders --reference my_route/reference --query my_route/query
       vpr-smr dataset check --config my.yaml
  2. run the whole workflow of a configuration: descriptors, distances, predictor, tables, report.html
       vpr-smr run my.yaml
  3. or score a distance matrix of your own method (references x queries, .npy) stage by stage
       vpr-smr attributes --distances D.npy --seq-len 4 --out attributes.csv
       vpr-smr metrics --distances D.npy --seq-len 4 --out metrics.json
       vpr-smr queries --distances D.npy --seq-len 4 --out queries.csv
"""
EPILOG = """\
A configuration to start from: configs/own_folders.yaml in a checkout (two image folders of your own).
vpr-smr backends lists the descriptor backends with their settings.
vpr-smr COMMAND --help shows a command's options; vpr-smr --debug COMMAND ... shows an error's traceback.
"""

def build_parser(matcher: str = DEFAULT_MATCHER, job: bool = False) -> argparse.ArgumentParser:
    """The ``vpr-smr`` command line; the stage commands' ``--matcher`` options are those of ``matcher``'s
    settings (``main`` reads ``--matcher`` first); ``job``: the command line gives a stage's ``--job``."""
    parser = argparse.ArgumentParser(prog="vpr-smr", description=DESCRIPTION, epilog=EPILOG,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"%(prog)s {package_version()}",
                        help="the installed version (the package metadata's); cite it with your results")
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    parser.add_argument("--debug", action="store_true", help="show the Python traceback of an error")
    sub = parser.add_subparsers(dest="command", required=True, title="commands", metavar="COMMAND")

    p = sub.add_parser("dataset", help="check a dataset on disk before a run (start here)")
    dataset_sub = p.add_subparsers(dest="dataset_command", required=True)
    c = dataset_sub.add_parser(
        "check", help="verify a dataset on disk before a long run",
        description="Every image is found and decoded; prints the frames per traverse and split, the order and "
                    "pairing of the frames, and every problem. The options are the configuration's keys.",
        epilog="e.g. vpr-smr dataset check folders --reference my_route/reference --query my_route/query "
               "--splits train=0:100 val=100:150 test=150:300;  vpr-smr dataset check nordland --root /data/nordland;"
               "  vpr-smr dataset check --config my.yaml --dataset my_route")
    c.add_argument("name", nargs="?", help="loader: folders, nordland_sample, nordland, robotcar, sfu_mountain")
    c.add_argument("--config", help="take the dataset's settings from this configuration file")
    c.add_argument("--dataset", help="with --config: which of its datasets (default: its only one)")
    c.add_argument("--root", help="the dataset's folder (benchmark loaders)")
    c.add_argument("--reference", help="folders: the reference traverse's image folder")
    c.add_argument("--query", help="folders: the query traverse's image folder")
    c.add_argument("--reference-list", help="a frame list naming the reference frames in order")
    c.add_argument("--query-list", help="a frame list naming the query frames in order")
    c.add_argument("--pairing", choices=("by_name", "by_order"), help="folders: how frame i of both is paired")
    c.add_argument("--tolerance", type=int, help="frames of ground-truth tolerance (default 2)")
    c.add_argument("--reference-positions", help="folders: a CSV (name,x,y or name,lat,lon) of the reference frames")
    c.add_argument("--query-positions", help="folders: a CSV (name,x,y or name,lat,lon) of the query frames")
    c.add_argument("--positions", help="positions from the names (folders: file_names) or the INS logs (robotcar: ins)")
    c.add_argument("--radius", type=float, help="with positions: a match is correct within this distance")
    c.add_argument("--frames", metavar="LO:HI", help="keep frames LO .. HI-1 only")
    c.add_argument("--splits", nargs="+", metavar="NAME=LO:HI",
                   help="e.g. train=0:40 val=40:70 test=70:111; with positions NAME=LO:HI/LO:HI gives the "
                        "reference and the query range apart")
    c.add_argument("--option", action="append", metavar="KEY=VALUE", help="any other loader setting (repeatable)")
    c.add_argument("--no-decode", dest="decode", action="store_false", help="only look for the files")
    c.set_defaults(func=cmd_dataset_check)

    p = sub.add_parser("run", help="run the whole workflow of a configuration with Snakemake")
    p.add_argument("config", help="the run's configuration (.yaml), e.g. configs/own_folders.yaml")
    p.add_argument("--cores", type=int, help="default: the profile's (local: 2)")
    p.add_argument("--config", dest="set", action="append", metavar="KEY=VALUE",
                   help="override a setting, dotted keys for nested ones: --config predictor.max_iter=500")
    p.add_argument("--profile", default="local", help="a shipped profile (local, slurm) or a profile folder")
    p.add_argument("-n", "--dry-run", action="store_true", help="only count the jobs that would run, per rule")
    # Its own dest: a subcommand's default would overwrite the global -v/--verbose (`vpr-smr -v run` works too).
    p.add_argument("-v", "--verbose", dest="snakemake_output", action="store_true",
                   help="show Snakemake's own output instead of the progress view (which logs it under "
                        "<run folder>/logs/snakemake-<time>.log)")
    p.epilog = "Arguments after a lone -- go to snakemake unchanged, e.g. vpr-smr run c.yaml -- --forceall"
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("backends", help="list the descriptor backends: checkpoint, input size, default settings",
                       description="Every descriptor backend (built in, or registered by an installed package) with "
                                   "whether it needs a checkpoint, its distance, the input size of its official "
                                   "evaluation and its default settings.")
    p.set_defaults(func=cmd_backends)

    p = sub.add_parser("matchers", help="list the sequence matchers: description, native confidence, settings",
                       description="Every sequence matcher (built in, or registered by an installed package through "
                                   "the entry point group vpr_smr.matchers) with its native confidence and each "
                                   "setting's default and help.")
    p.set_defaults(func=cmd_matchers)

    p = sub.add_parser("checkpoint", help="checkpoint tools")
    checkpoint_sub = p.add_subparsers(dest="checkpoint_command", required=True)
    c = checkpoint_sub.add_parser("check", help="load a downloaded checkpoint exactly as the pipeline would")
    c.add_argument("method", help="backend name, e.g. netvlad, cosplace, salad")
    c.add_argument("file", help="the downloaded checkpoint file")
    c.add_argument("--option", action="append", metavar="KEY=VALUE", help="a backend setting (repeatable)")
    c.set_defaults(func=cmd_checkpoint_check)

    p = sub.add_parser("convert-checkpoint", help="turn an official pickle into a plain tensor file (apgem)")
    p.add_argument("method", help="the backend whose release needs converting (apgem)")
    p.add_argument("input", help="the official file, e.g. Resnet-101-AP-GeM.pt")
    p.add_argument("output", help="the plain tensor file to write; set it as the method's checkpoint")
    p.set_defaults(func=cmd_convert_checkpoint)

    # the stages, declared once (pipeline.stages), in the data flow's order; a plugin experiment's after them
    for stage in (*STAGES, *plugin_stages()):
        install(sub, stage, matcher, job, COMMAND_GROUPS)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    # `run ... -- <snakemake arguments>`: split by hand, so that our own options may come in any order.
    extra = argv[argv.index("--") + 1 :] if "--" in argv else []
    argv = argv[: argv.index("--")] if "--" in argv else argv
    args = build_parser(matcher_of(argv), JOB in argv or any(word.startswith(JOB + "=") for word in argv)
                        ).parse_args(argv)
    args.snakemake_args = extra
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO, format=LOG_FORMAT)
    # A stage stopped by SIGTERM unwinds like Ctrl-C, so that its temporary files are removed on the way out.
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        status = args.func(args)
    except KeyboardInterrupt:
        print(f"vpr-smr {args.command}: interrupted; nothing was written under a final name", file=sys.stderr)
        return 130
    except Exception as error:
        if args.debug:
            raise
        known = isinstance(error, ConfigError | ValueError | OSError)
        hint = "" if known else f" ({type(error).__name__}; run with --debug for the traceback)"
        print(f"vpr-smr {args.command}: error: {error}{hint}", file=sys.stderr)
        return 2
    return int(status or 0)


def run() -> None:
    """The ``vpr-smr`` program: ``main`` on this process's arguments, then the process ends with its status."""
    status = main()
    # Nothing is collected after this: the interpreter's exit then skips the collections that free every module's
    # cycles one by one (about half of the 40-90 ms a 9000 x 9000 `vpr-smr attributes` took to exit); exit
    # handlers run as before.
    gc.freeze()
    sys.exit(status)


def _interrupt(signum: int, _frame: Any) -> None:
    raise KeyboardInterrupt


if __name__ == "__main__":
    run()
