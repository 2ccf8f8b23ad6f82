"""What every job of a run needs, worked out once before the first job: the checks and the per-job settings.

``preflight`` checks everything that can be checked without computing anything (datasets on disk, split
ranges against the sequence lengths, backends and their settings, checkpoints, the output folder) and returns
a ``Plan``. The Snakefile hands each job exactly the settings it uses as ``params`` and the files it reads as
``input``, both taken from the plan, so that changing a setting reruns exactly the jobs it affects.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from vpr_smr.datasets.base import GroundTruthFile, relative_note
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.pipeline.config import Config, ConfigError, experiments


@dataclass(frozen=True)
class DatasetPlan:
    """A dataset as the jobs see it, with the loader's defaults resolved."""

    frames_settings: dict[str, Any]  # the configuration entry without splits and tolerance
    splits: dict[str, tuple[int, int]]
    tolerance: int
    n_frames: int  # the reference traverse's frames
    n_query_frames: int  # the query traverse's frames: n_frames for a frame-aligned pair, its own with positions
    frames_sha256: str  # fingerprint of the ordered frame names of both traverses
    list_files: tuple[str, ...]  # frame-list files named in the configuration (inputs of the descriptors jobs)
    pairing: str  # how frame i of both traverses is known to be one place
    traverses: tuple[str, str]  # the reference's and the query's name
    warnings: tuple[str, ...]  # e.g. a frame order taken from file names that do not say it unambiguously
    overlaps: tuple[str, ...]  # splits that share frames (only with allow_split_overlap), e.g. "train and test: 40-59"
    source: str  # where the images came from: the loader and its own description (``TraversePair.source``)
    # method §11, datasets with positions only: the ground truth's radius (None: frame-aligned, `tolerance` applies),
    # the reference ranges of splits that give them apart (`splits` holds the query ranges), and the positions
    # files named in the configuration (inputs of the descriptors jobs, as the frame lists)
    radius: float | None = None
    reference_splits: dict[str, tuple[int, int]] = field(default_factory=dict)
    positions_files: tuple[str, ...] = ()
    # method §13: the ground truth from a file (None: `tolerance` or `radius`), and how it reads ("gt.npy (a matrix)")
    ground_truth: GroundTruthFile | None = None
    ground_truth_text: str = ""

    @property
    def truth(self) -> TruthSource:
        """The dataset's ground truth as the stages' option group (frame tolerance, radius or file; the positions
        travel in its distance files)."""
        given = self.ground_truth
        return TruthSource(tolerance=self.tolerance, radius=self.radius,
                           ground_truth=None if given is None else given.path,
                           ground_truth_key=None if given is None else given.key)

    @property
    def has_tolerance(self) -> bool:
        """Whether a match is correct within ``tolerance`` frames: a frame-aligned pair without a ground-truth file
        (the speed experiment and the protocol sweep's frame tolerances need it)."""
        return self.radius is None and self.ground_truth is None

    def reference_range(self, split: str) -> tuple[int, int]:
        """A split's reference range: its own, or its (query) range."""
        return self.reference_splits.get(split, self.splits[split])


@dataclass(frozen=True)
class Plan:
    datasets: dict[str, DatasetPlan]
    checkpoints: dict[str, str | None]  # method -> checkpoint file the descriptors job reads, if any
    warnings: tuple[str, ...] = ()  # worth reading before a long run, not wrong (e.g. an ambiguous frame order)
    metrics: dict[str, str] = field(default_factory=dict)  # method -> its distance (the distances jobs' setting)


PLAN_ENV = "VPR_SMR_PLAN"  # the plan file `vpr-smr run` hands to Snakemake (and to cluster jobs that parse it)


def _config_digest(conf: Config) -> str:
    return hashlib.sha256(canonical(conf.to_json()).encode()).hexdigest()


def plan_to_json(plan: Plan, conf: Config) -> dict[str, Any]:
    """The plan with the digest of the validated configuration it was made for."""
    return {"config_sha256": _config_digest(conf), "plan": asdict(plan)}


def plan_from_json(data: dict[str, Any], conf: Config) -> Plan | None:
    """The plan of ``plan_to_json``, or None when it was made for another configuration."""
    if data.get("config_sha256") != _config_digest(conf):
        return None
    plan = data["plan"]
    names = {f.name for f in fields(DatasetPlan)}
    if any(set(d) != names for d in plan["datasets"].values()):
        return None  # written by another version of DatasetPlan: plan again
    datasets = {name: DatasetPlan(**{
        **d,
        **{key: {k: (int(lo), int(hi)) for k, (lo, hi) in d[key].items()} for key in ("splits", "reference_splits")},
        **{key: tuple(d[key]) for key in ("list_files", "overlaps", "traverses", "warnings", "positions_files")},
        "ground_truth": None if d["ground_truth"] is None else GroundTruthFile(**d["ground_truth"]),
    }) for name, d in plan["datasets"].items()}
    return Plan(datasets, dict(plan["checkpoints"]), tuple(plan["warnings"]), dict(plan["metrics"]))


def save_plan(plan: Plan, conf: Config, folder: Path | None = None) -> Path:
    """Write the plan where Snakemake and its jobs find it (``PLAN_ENV``); named by the configuration's digest
    (``core.paths.plan_path``, or in ``folder``)."""
    from vpr_smr.core.io import atomic_path
    from vpr_smr.core.paths import plan_path

    path = plan_path(_config_digest(conf))
    path = path if folder is None else folder / path.name
    with atomic_path(path) as tmp:  # not sorted: the datasets and splits keep the configuration's order
        tmp.write_text(json.dumps(plan_to_json(plan, conf)))
    return path


def planned(conf: Config) -> Plan:
    """The plan ``vpr-smr run`` made for this configuration (the file named by ``PLAN_ENV``), so that the checks run
    once per run and not again when Snakemake, or a cluster job, parses the workflow; otherwise ``preflight``."""
    path = os.environ.get(PLAN_ENV)
    if path and Path(path).is_file():
        plan = plan_from_json(json.loads(Path(path).read_text()), conf)
        if plan is not None:
            return plan
    return preflight(conf)


def dataset_cards(plan: Plan) -> dict[str, dict[str, Any]]:
    """What the report states of each dataset: traverses, frames, tolerance, splits, pairing, overlaps, the frame
    lists' SHA-256 and where the images came from; a dataset with positions (method §11) adds its radius, the
    reference ranges that differ from its splits' (query) ranges and the query traverse's frames (``n_frames`` are
    the reference's)."""
    return {name: {"reference": d.traverses[0], "query": d.traverses[1], "n_frames": d.n_frames,
                   "tolerance": d.tolerance, "splits": {k: list(v) for k, v in d.splits.items()},
                   "pairing": d.pairing, "overlaps": list(d.overlaps), "frames_sha256": d.frames_sha256,
                   "source": d.source, **_positions_card(d), **_ground_truth_card(d)}
            for name, d in plan.datasets.items()}


def _ground_truth_card(d: DatasetPlan) -> dict[str, Any]:
    """A card's entry of a dataset whose ground truth is a file (method §13); none otherwise."""
    return {} if d.ground_truth is None else {"ground_truth": d.ground_truth_text}


def _positions_card(d: DatasetPlan) -> dict[str, Any]:
    """A card's entries of a dataset with positions; none for a frame-aligned one (its card stays as it was)."""
    if d.radius is None:
        return {}
    return {"radius": d.radius, "reference_splits": {k: list(v) for k, v in d.reference_splits.items()},
            "n_query_frames": d.n_query_frames}


def canonical(value: Any) -> str:
    """Settings as a canonical JSON text: equal settings give equal text (the form a job's params take)."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"))


def _list_files(settings: dict[str, Any]) -> tuple[str, ...]:
    return tuple(str(v) for k, v in sorted(settings.items()) if k.endswith("_list") and v)


def _positions_files(settings: dict[str, Any]) -> tuple[str, ...]:
    """The positions CSVs of a dataset entry (``reference_positions``, ``query_positions``)."""
    return tuple(str(v) for k, v in sorted(settings.items()) if k.endswith("_positions") and v)


def _shared(a: tuple[int, int], b: tuple[int, int]) -> tuple[int, int] | None:
    lo, hi = max(a[0], b[0]), min(a[1], b[1])
    return (lo, hi) if lo < hi else None


def split_overlaps(splits: dict[str, tuple[int, int]],
                   reference_splits: dict[str, tuple[int, int]] | None = None) -> list[str]:
    """Every two splits that share frames, as ``'train' [0, 60) and 'test' [40, 111) share frames [40, 60)``.

    ``splits`` are the query ranges; where a split gives its reference range apart (``reference_splits``,
    method §11), the reference ranges are compared too, and each message says which frames are shared.
    """
    reference_splits = reference_splits or {}
    found = []
    names = list(splits)
    for i, first in enumerate(names):
        for second in names[i + 1 :]:
            a, b = splits[first], splits[second]
            if first not in reference_splits and second not in reference_splits:
                if (s := _shared(a, b)) is not None:
                    found.append(f"{first!r} [{a[0]}, {a[1]}) and {second!r} [{b[0]}, {b[1]}) share frames "
                                 f"[{s[0]}, {s[1]})")
                continue
            ref_a, ref_b = reference_splits.get(first, a), reference_splits.get(second, b)
            for role, (x, y) in (("query", (a, b)), ("reference", (ref_a, ref_b))):
                if (s := _shared(x, y)) is not None:
                    found.append(f"{first!r} {role} range [{x[0]}, {x[1]}) and {second!r} {role} range "
                                 f"[{y[0]}, {y[1]}) share {role} frames [{s[0]}, {s[1]})")
    return found


def _training_problems(conf: Config, train: tuple[int, int]) -> list[str]:
    """Whether the train split is long enough to train every predictor of the run, at the longest ``seq_lens``
    (the fewest samples); the leave-one-method-out predictors pool one method less."""
    from vpr_smr.eval.predictor.defaults import training_problems

    n_methods = len(conf.methods)
    if "leave_one_method_out" in experiments(conf):
        n_methods -= 1
    return training_problems(train[1] - train[0], max(conf.seq_lens), n_methods,
                             smote=conf.predictor.smote, split=conf.train_split)


def _experiment_off(conf: Config, seq_len: int) -> str:
    """The other way out for a compared matcher that cannot match a split at ``seq_len``: the experiment that runs
    it there off."""
    if seq_len == conf.table_seq_len:
        return " (or switch the experiment off: experiments.matchers: false)"
    return (" (or switch the experiment off: experiments.adaptive_seq_len: false, which runs the compared matchers at "
            "every length of seq_lens)")


def _matcher_problems(conf: Config, name: str, pair: Any, splits: list[str]) -> list[str]:
    """Whether the matcher (``sequence_matching``) can match every split at every ``L`` of ``seq_lens``, and each
    matcher the experiment ``matchers`` compares every split at ``table_seq_len`` (at every ``L`` with the
    experiment ``adaptive_seq_len``, which runs them all there): its own ``Matcher.check`` on the
    split's shape, references x queries (SeqSLAM's velocity search needs its slowest trajectory's references,
    method §11; a centred window more queries than ``L``). Only what the sequence-length check does not already
    say: splits of at least ``L`` references and queries. The matchers' settings were checked with the
    configuration (``Matcher.settings_of``)."""
    checks = [(conf.sequence_matching, conf.seq_lens, "sequence_matching")]
    chosen = experiments(conf)
    if "matchers" in chosen:
        lengths = conf.seq_lens if "adaptive_seq_len" in chosen else (conf.table_seq_len,)
        checks += [(spec, lengths, "matchers") for spec in conf.matchers if spec != conf.sequence_matching]
    problems = []
    for spec, seq_lens, setting in checks:
        for split in splits:
            (r_lo, r_hi), (q_lo, q_hi) = pair.reference_range(split), pair.splits[split]
            shape = (r_hi - r_lo, q_hi - q_lo)
            for seq_len in sorted(seq_lens, reverse=True):  # the longest sequence needs the most frames
                if min(shape) < seq_len:
                    continue
                try:
                    spec.build(seq_len).check(shape, f"split {split!r}")
                except ValueError as error:
                    problems.append(f"datasets.{name}: split {split!r} (references [{r_lo}, {r_hi}), queries "
                                    f"[{q_lo}, {q_hi})) cannot be matched by the matcher {spec} ({setting}) at "
                                    f"sequence length {seq_len}: {error}; lengthen the split (its reference or query "
                                    f"range), or change {setting}"
                                    + (_experiment_off(conf, seq_len) if setting == "matchers" else ""))
                    break
    return problems


def _speed_problems(conf: Config, name: str, splits: dict[str, tuple[int, int]], trainable: bool
                    ) -> list[str]:
    """What the speed experiment (method §11, ``eval.scoring.speed``) needs of a frame-aligned dataset, at
    ``table_seq_len``: each profile's simulated train and table query at least ``L`` frames long, the simulated
    train split enough samples to train the pooled predictor of every method (``training_problems``, the rule of
    the aligned train split), and the aligned splits (the references) the velocity matcher's longest trajectory.
    Splits the checks before already found too short (or, for training, the aligned train split) are not
    checked again."""
    from vpr_smr.eval.matching.matcher import SequenceMatcher
    from vpr_smr.eval.predictor.defaults import MIN_TRAIN_SAMPLES, training_problems
    from vpr_smr.eval.scoring.speed import SpeedProfile, simulate

    seq_len = int(conf.table_seq_len)
    longest = max(conf.seq_lens)
    velocities = [float(v) for v in conf.speed.velocities]
    need = SequenceMatcher(seq_len, tuple(velocities)).references_needed
    profiles = [SpeedProfile.parse(value) for value in conf.speed.profiles]
    fix = "experiments: {speed: false}"
    problems = []
    for role, split in (("train_split", conf.train_split), ("table_split", conf.table_split)):
        if split not in splits or splits[split][1] - splits[split][0] < longest:
            continue  # not defined, or too short for the sequences: said before
        lo, hi = splits[split]
        where = f"datasets.{name}: speed experiment, split {split!r} [{lo}, {hi}) ({role})"
        if need > max(seq_len, hi - lo):
            problems.append(f"{where}: velocity search at sequence length {seq_len} (table_seq_len) with velocities "
                            f"{velocities} (speed.velocities) needs at least {need} reference frames, the split has "
                            f"{hi - lo}: lengthen the split, give smaller speed.velocities, or switch the experiment "
                            f"off ({fix})")
        for profile in profiles:
            n_queries = len(simulate(profile, lo, hi)[0])
            drop = f"drop {profile.name} from speed.profiles, lengthen split {split!r}, or set {fix}"
            if n_queries < seq_len:
                problems.append(f"{where}: the {profile.name} profile leaves {n_queries} queries, fewer than the "
                                f"sequence length {seq_len} (table_seq_len): {drop}")
                continue
            if role != "train_split" or not trainable:
                continue
            n_methods, smote = len(conf.methods), conf.predictor.smote
            if training_problems(n_queries, seq_len, n_methods, smote=smote, split=split):  # the aligned split's rule
                per_method = n_queries - seq_len + 1
                problems.append(f"{where}: the {profile.name} profile leaves {n_queries} queries, {per_method} "
                                f"training samples per method at sequence length {seq_len} (table_seq_len), "
                                f"{per_method * n_methods} pooled over {n_methods} method(s); the experiment's "
                                f"pooled predictor needs at least {MIN_TRAIN_SAMPLES[smote]}: {drop}")
    return problems


def _check_datasets(conf: Config, problems: list[str]) -> dict[str, DatasetPlan]:
    from vpr_smr.datasets import DatasetError, frames_settings, load_dataset

    needed = list(dict.fromkeys([conf.train_split, *conf.eval_splits, conf.table_split]))
    longest = max(conf.seq_lens)
    plans = {}
    for name, settings in conf.datasets.items():
        dataset = settings.to_json()  # the entry as given: the loader reads its own keys
        root = settings.root
        if "root" in dataset and not root:
            problems.append(f"datasets.{name}.root is not set: give the folder where dataset {name!r} is on disk")
            continue
        try:
            pair = load_dataset(name, dataset)
        except DatasetError as error:
            note = relative_note(root) if root and not Path(root).exists() else ""
            problems.append(f"{error}{'' if note in str(error) else note}")  # said once, if the loader said it
            continue
        for split in needed:
            if split not in pair.splits:
                problems.append(f"datasets.{name}: split {split!r} (named in train_split, eval_splits or "
                                f"table_split) is not defined; it has {', '.join(pair.splits) or 'none'}")
                continue
            for role, (lo, hi) in (("", pair.splits[split]), (" reference range", pair.reference_range(split))):
                if hi - lo < longest and (not role or split in pair.reference_splits):
                    problems.append(f"datasets.{name}: split {split!r}{role} has {hi - lo} frames, fewer than the "
                                    f"sequence length {longest} (seq_lens): lengthen the split or shorten the "
                                    "sequences")
        problems.extend(_matcher_problems(conf, name, pair, [s for s in needed if s in pair.splits]))
        train = pair.splits.get(conf.train_split)
        trainable = False
        if train is not None and train[1] - train[0] >= longest:
            found = _training_problems(conf, train)
            problems.extend(f"datasets.{name}: {problem}" for problem in found)
            trainable = not found
        truth_notes: list[str] = []
        truth_text = ground_truth_problems(name, pair, [s for s in conf.eval_splits if s in pair.splits], problems,
                                            truth_notes)
        if pair.radius is None and pair.ground_truth is None and "speed" in experiments(conf):  # SPEED_DATASETS
            problems.extend(_speed_problems(conf, name, pair.splits, trainable))
        overlaps = split_overlaps({split: pair.splits[split] for split in needed if split in pair.splits},
                                  pair.reference_splits)
        if overlaps and not conf.allow_split_overlap:
            problems.extend(
                f"datasets.{name}: splits {overlap}: the predictor would be scored on "
                "frames it was trained or validated on. Make the split ranges disjoint, or set "
                "allow_split_overlap: true for a deliberate experiment (every table then says so)"
                for overlap in overlaps
            )
        for path in _list_files(dataset):
            if not Path(path).is_file():
                problems.append(f"datasets.{name}: frame list not found: {path}{relative_note(path)}")
        plans[name] = DatasetPlan(
            frames_settings=frames_settings(dataset),
            splits={k: (int(lo), int(hi)) for k, (lo, hi) in pair.splits.items()},
            tolerance=pair.tolerance,
            n_frames=len(pair),
            n_query_frames=len(pair.query),
            frames_sha256=pair.fingerprint(),
            list_files=_list_files(dataset),
            pairing=pair.pairing,
            traverses=(pair.reference.name, pair.query.name),
            warnings=tuple(f"datasets.{name}: {t.name} frames: {t.order_note}"
                           for t in (pair.reference, pair.query) if t.order_note) + tuple(truth_notes),
            overlaps=tuple(overlaps),
            source=f"{settings.loader} loader: {pair.source}",
            radius=pair.radius,
            reference_splits=dict(pair.reference_splits),
            positions_files=_positions_files(dataset),
            ground_truth=pair.ground_truth,
            ground_truth_text=truth_text,
        )
    return plans


def ground_truth_problems(name: str, pair: Any, eval_splits: list[str], problems: list[str],
                           notes: list[str]) -> str:
    """Check a dataset's ground-truth file (method §13) before any job: found, of the form the configuration says,
    one entry per frame of both traverses (lists: every index in range); a note per evaluation split with queries
    that have no correct reference (they count as wrong in every denominator). Returns how the tables name it."""
    from vpr_smr.eval.matching.ground_truth_files import read_ground_truth

    given = pair.ground_truth
    if given is None:
        return ""
    where = f"datasets.{name}.ground_truth.{given.form}"
    if not Path(given.path).is_file():
        problems.append(f"{where}: file not found: {given.path} (a relative path is looked for from the "
                        "configuration's folder)")
        return ""
    shape = (len(pair.reference), len(pair.query))
    try:
        truth = read_ground_truth(given.path, given.key, shape, key_option=f"datasets.{name}.ground_truth.key")
    except (OSError, ValueError) as error:
        problems.append(f"{where}: {error} (the dataset has {shape[0]} reference and {shape[1]} query frames)")
        return ""
    source = getattr(truth, "source", None)
    lists = source is not None and source.lists
    if lists != (given.form == "lists"):
        held, form = ("per-query lists", "lists") if lists else ("a matrix", "matrix")
        problems.append(f"{where}: {given.path} holds {held}: write it as ground_truth: {{{form}: ...}} "
                        f"instead, or give the other file")
        return ""
    for split in eval_splits:
        lo, hi = pair.splits[split]
        missing = int(truth.sliced(pair.reference_range(split), (lo, hi)).without_correct().sum())
        if missing:
            notes.append(f"datasets.{name}: {missing} of the {hi - lo} queries of split {split!r} have no correct "
                         f"reference in {Path(given.path).name}: they count in every recall and precision, never "
                         "as correct (method §13)")
    return truth.describe()


def _file_stamp(path: Path | str) -> list[Any]:
    info = Path(path).stat()
    return [str(Path(path).resolve()), info.st_size, info.st_mtime_ns]


def _method_key(method: dict[str, Any]) -> str | None:
    """What a method's check depends on: its settings, its checkpoint file, the package version and the descriptors
    package's source files (a code change of an editable install keeps the version; backends share modules, e.g.
    MegaLoc and BoQ the DINOv2 of dinov2.py and SALAD's aggregation); None, so checked every time, when the
    checkpoint is not a file here or the backend is a plugin."""
    from vpr_smr.core.io import package_version
    from vpr_smr.descriptors import BACKENDS

    if method["backend"] not in BACKENDS.builtins():
        return None
    package = Path(__file__).resolve().parents[1] / "descriptors"
    sources = [_file_stamp(path) for path in sorted(package.glob("*.py"))]
    checkpoint = method.get("checkpoint")
    stamp = None
    if checkpoint and checkpoint != "package":
        if not Path(checkpoint).is_file():
            return None
        stamp = _file_stamp(checkpoint)
    return canonical({"method": method, "checkpoint": stamp, "version": package_version(), "sources": sources})


def _checked_before() -> dict[str, dict[str, Any]]:
    from vpr_smr.core.paths import methods_checked_path

    try:
        checked: dict[str, dict[str, Any]] = json.loads(methods_checked_path().read_text())
        return checked
    except (OSError, ValueError):
        return {}


def _check_methods(conf: Config, problems: list[str], metrics: dict[str, str]) -> dict[str, str | None]:
    """Every backend, backend setting and checkpoint (keys and shapes, strictly). A method whose settings and
    checkpoint file are unchanged since its check last passed is not checked again: loading PyTorch and a
    checkpoint would otherwise cost seconds on every run, also one that has nothing to do."""
    checked = _checked_before()
    passed: dict[str, dict[str, Any]] = {}
    checkpoints = {}
    for name, settings in conf.methods.items():
        method = settings.to_json()  # the entry as given: the backend reads its own settings
        checkpoint = settings.checkpoint
        checkpoints[name] = checkpoint if checkpoint and checkpoint != "package" else None
        key = _method_key(method)
        if key is not None and key in checked:
            metrics[name] = checked[key]["metric"]
            passed[key] = checked[key]
            continue
        metric = _check_method(name, method, problems)
        if metric is not None:
            metrics[name] = metric
            if key is not None:
                passed[key] = {"metric": metric}
    if not passed.keys() <= checked.keys():
        from vpr_smr.core.io import atomic_path
        from vpr_smr.core.paths import methods_checked_path

        try:  # merged: switching between configurations keeps both checks
            with atomic_path(methods_checked_path()) as tmp:
                tmp.write_text(json.dumps({**checked, **passed}))
        except OSError:
            pass  # a read-only working folder: the checks simply run again next time
    return checkpoints


def _check_method(name: str, method: dict[str, Any], problems: list[str]) -> str | None:
    """Check one method; its distance when the check passes, else None (the problems are appended)."""
    from vpr_smr.descriptors import backend_class
    from vpr_smr.descriptors.extract import check_checkpoint

    try:
        cls = backend_class(method["backend"])
    except (ValueError, ImportError) as error:
        problems.append(f"methods.{name}.backend: {error}")
        return None
    checkpoint = method.get("checkpoint")
    if cls.needs_checkpoint and not checkpoint:
        problems.append(f"methods.{name}.checkpoint is not set: backend {method['backend']!r} needs the path "
                        "of its downloaded checkpoint file")
        return None
    if checkpoint and checkpoint != "package" and not Path(checkpoint).is_file():
        problems.append(f"methods.{name}.checkpoint: file not found: {checkpoint}{relative_note(checkpoint)}")
        return None
    try:  # every key and shape of the checkpoint, and every backend setting, before the first job
        check_checkpoint(method, method=name)
    except ValueError as error:
        problems.append(f"methods.{name}: {error}")
        return None
    return method.get("distance") or cls.distance


def _check_output(conf: Config, problems: list[str]) -> None:
    folder = conf.run_dir
    existing = next((p for p in (folder, *folder.parents) if p.exists()), Path("."))
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        problems.append(f"output: cannot write the run folder {folder}: {existing} is not a writable folder; "
                        "set `output` to a folder you can write")


def preflight(conf: Config, source: str = "the configuration") -> Plan:
    """Check a validated configuration; one ConfigError lists every problem found (``source``: the file, for the
    message)."""
    problems: list[str] = []
    datasets = _check_datasets(conf, problems)
    metrics: dict[str, str] = {}
    checkpoints = _check_methods(conf, problems, metrics)
    _check_output(conf, problems)
    if problems:
        raise ConfigError(f"{source} cannot run:\n  " + "\n  ".join(problems))
    return Plan(datasets, checkpoints, tuple(warning for d in datasets.values() for warning in d.warnings), metrics)
