"""What `vpr-smr run` shows while Snakemake runs: a compact progress view, Snakemake's own output in a log file.

Snakemake's text is read line by line (its job, progress and error messages, stable within Snakemake 9) rather
than through a logger plugin, which Snakemake finds only as a top-level ``snakemake_logger_plugin_*`` package.
"""

from __future__ import annotations

import queue
import re
import shutil
import subprocess
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import timedelta
from pathlib import Path
from typing import Protocol, TextIO

from vpr_smr.core.progress import Progress, read_progress

TAIL_LINES = 15  # of a failed job's log, or of Snakemake's output when no job failed
# Output that is not a terminal gets a line per running job this often, so that a long job does not look stuck.
REPORT_EVERY_S = 30.0
READ_EVERY_S = 1.0  # the running jobs' logs are read at most this often for the line redrawn on a terminal
SHOWN_JOBS = 8  # running jobs named in the line redrawn on a terminal

JOB_INFO = re.compile(r"(?:local)?(?:rule|checkpoint) (\S+):")
JOB_ERROR = re.compile(r"Error in rule (\S+):")
FIELD = re.compile(r"    (\w+): (.*)")
FINISHED = re.compile(r"Finished jobid: (\d+) \(Rule: \S+\)")
PROGRESS = re.compile(r"(\d+) of (\d+) steps \(.*\) done")
TOTAL = re.compile(r"total\s+(\d+)")  # the last row of Snakemake's "Job stats" table
LOG_SHOWN = re.compile(r"Logfile .*:")  # then a failed job's log between two "====" lines (show-failed-logs)
RULER = re.compile(r"=+")
STAGE_ERROR = re.compile(r"vpr-smr \S.*?: error: .*")  # the one line a failed stage prints (pipeline/cli.py)
LOG_FORMAT = "%(asctime)s %(name)s %(levelname)s: %(message)s"  # a stage's log lines (pipeline/cli.py sets it)
WARNING_LINE = re.compile(r"\S+ \S+ \S+ WARNING: (.*)")  # a warning in that format: date, time, logger, level
NOTHING_TO_DO = "Nothing to be done"
LOG_HINT = " (check log file(s) for error details)"


@dataclass
class Job:
    """One job as Snakemake describes it: its rule and the ``key: value`` lines below the rule's name."""

    rule: str
    fields: dict[str, str] = field(default_factory=dict)

    @property
    def jobid(self) -> str | None:
        return self.fields.get("jobid")

    def wildcards(self) -> list[tuple[str, str]]:
        pairs = [item.partition("=") for item in self.fields.get("wildcards", "").split(", ") if item]
        return [(name, value) for name, _, value in pairs]

    def label(self) -> str:
        """``rule value/value/...``, e.g. ``attributes sample/sad/L3/test``, in the order of the file paths."""
        values = [f"L{value}" if name == "seq_len" else value for name, value in self.wildcards()]
        return " ".join([self.rule, "/".join(values)]) if values else self.rule

    def log_files(self) -> list[Path]:
        """The job's log files; Snakemake lists several with ", ", which a path may hold too."""
        text = self.fields.get("log", "").removesuffix(LOG_HINT)
        if not text:
            return []
        return [Path(text)] if Path(text).is_file() else [Path(p) for p in text.split(", ") if Path(p).is_file()]

    def progress(self) -> Progress | None:
        """The last progress state the job's stage wrote into its log (``core.progress``), if any."""
        return next((state for log in reversed(self.log_files()) if (state := read_progress(log))), None)


class SnakemakeOutput:
    """Snakemake's output parsed line by line: the jobs that started, finished and failed, and the step counts.

    ``feed`` and ``flush`` return the events of the lines read so far: ``("started" | "done" | "failed", job)``.
    A job's description ends at the first line that is not one of its fields, or at ``flush`` (Snakemake writes it
    at once, then nothing until the job ends).
    """

    def __init__(self) -> None:
        self.jobs: dict[str, Job] = {}
        self.running: dict[str, Job] = {}
        self.failed: list[Job] = []
        self.done = 0
        self.total: int | None = None
        self.nothing_to_do = False
        self._block: tuple[str, Job] | None = None  # ("started" | "failed", the job being described)
        self._finished: Job | None = None  # reported done with the step count that follows it
        self._ruler: str | None = None  # inside a failed job's log that Snakemake shows: skipped to this line
        self._log_next = False

    def feed(self, line: str) -> list[tuple[str, Job]]:
        line = line.rstrip("\r\n")
        if self._ruler is not None:  # a job's own log: its text is not Snakemake's
            if line == self._ruler:
                self._ruler = None
            return []
        if self._log_next:
            self._log_next = False
            if RULER.fullmatch(line):
                self._ruler = line
                return []
        if self._block and (match := FIELD.fullmatch(line)):
            self._block[1].fields.setdefault(match[1], match[2])
            return []
        events = self.flush()
        if match := JOB_INFO.fullmatch(line):
            self._block = ("started", Job(match[1]))
        elif match := JOB_ERROR.fullmatch(line):
            self._block = ("failed", Job(match[1]))
        elif match := FINISHED.fullmatch(line):
            self._finished = self.running.pop(match[1], None) or self.jobs.get(match[1])
        elif match := PROGRESS.fullmatch(line):
            self.done, self.total = int(match[1]), int(match[2])
            if self._finished:
                events.append(("done", self._finished))
                self._finished = None
        elif self.total is None and (match := TOTAL.fullmatch(line)):
            self.total = int(match[1])
        elif LOG_SHOWN.fullmatch(line):
            self._log_next = True
        elif line.startswith(NOTHING_TO_DO):
            self.nothing_to_do = True
        return events

    def flush(self) -> list[tuple[str, Job]]:
        """End the job description being read, if any: its event."""
        if self._block is None:
            return []
        kind, job = self._block
        self._block = None
        jobid = job.jobid
        if jobid is None:  # not a job after all (a rule's name alone on a line)
            return []
        if kind == "started":
            self.jobs[jobid] = job
            self.running[jobid] = job
        else:
            # the log as the job's own description gave it: the error's may add the executor's logs
            job = Job(job.rule, {**job.fields, **self.jobs.get(jobid, Job(job.rule)).fields})
            self.running.pop(jobid, None)
            self.failed.append(job)
        return [(kind, job)]


def clock(seconds: float) -> str:
    return str(timedelta(seconds=int(seconds)))


def progress_text(progress: Progress) -> str:
    """``[desc ]done/total unit (percent %)[, rate]``; a rate below one per second as seconds each."""
    desc = f"{progress.desc} " if progress.desc else ""
    text = f"{desc}{progress.done}/{progress.total} {progress.unit} ({100 * progress.fraction:.0f} %)"
    rate = progress.rate
    if rate is None:
        return text
    return f"{text}, {rate:.1f} {progress.unit}/s" if rate >= 1 else f"{text}, {1 / rate:.1f} s each"


def stage_error(lines: list[str]) -> str | None:
    """The last ``vpr-smr <stage>: error: ...`` line of a job's log."""
    return next((line for line in reversed(lines) if STAGE_ERROR.fullmatch(line)), None)


def readable_lines(text: str) -> list[str]:
    """A log's lines as a terminal leaves them: of a line redrawn with ``\\r`` (a progress bar) its last state
    that is not blank; blank lines left out."""
    lines = []
    for line in text.split("\n"):
        states = [state.rstrip() for state in line.split("\r") if state.strip()]
        if states:
            lines.append(states[-1])
    return lines


def job_warnings(job: Job) -> list[str]:
    """The warnings a job's stage logged (``LOG_FORMAT``): a degenerate predictor, an input that looks wrong."""
    out = []
    for log in job.log_files():
        try:
            text = log.read_text(errors="replace")
        except OSError:  # removed meanwhile: nothing to show
            continue
        out += [match[1] for line in readable_lines(text) if (match := WARNING_LINE.fullmatch(line))]
    return out


def failure_report(job: Job) -> list[str]:
    """The failed job, the last lines of its log and the stage's one error line."""
    wildcards = job.fields.get("wildcards")
    report = [f"vpr-smr run: job failed: rule {job.rule}" + (f" ({wildcards})" if wildcards else "")]
    logs = job.log_files()
    if not logs:
        return [*report, f"  no log file{' at ' + job.fields['log'] if job.fields.get('log') else ''}"]
    for log in logs:
        lines = readable_lines(log.read_text(errors="replace"))
        error = stage_error(lines)
        tail = [line for line in lines if line != error][-TAIL_LINES:]
        report.append(f"  last lines of its log {log}:" if tail else f"  its log {log} is empty")
        report += [f"    {line}" for line in tail]
        if error:
            report.append(f"  {error}")
    return report


class View(Protocol):
    stopped: int | None  # the signal that stopped the run, set by the signal handler

    def feed(self, line: str) -> None: ...

    def idle(self) -> None: ...

    def close(self, status: int) -> None: ...


# Snakemake's reason for a job whose input file is newer than its outputs; it compares the contents only of inputs
# under its checksum size (--max-checksum-file-size, 1 MB by default), whose checksums it recorded
NEWER_INPUT = "Updated input files: "
FOLLOWS = ("Input files updated by another job", "Forced execution")  # said by the other jobs' lines, or ours


def why_jobs_run(lines: list[str]) -> list[str]:
    """Why each job of a dry run's output (Snakemake's job blocks: ``rule NAME:`` then ``    reason: ...``) runs,
    for the plan's reader: a count of the jobs whose outputs are missing, a line per job whose input is newer than
    its outputs (file times, e.g. a copy that did not keep them) or with another reason of Snakemake's, naming its
    first output; the target rule ``all``, the jobs that only read such jobs' outputs and those vpr-smr forces
    (named before the run) are left out. Empty without a job block."""
    jobs: list[tuple[str, str, str]] = []  # rule, first output, reason
    rule = output = ""
    for line in lines:
        found = JOB_INFO.fullmatch(line.strip()) if not line.startswith(" ") else None
        if found:
            rule, output = found.group(1), ""
            continue
        field = FIELD.fullmatch(line)
        if rule and field and field.group(1) == "output":
            output = field.group(2).split(", ")[0]
        elif rule and field and field.group(1) == "reason":
            jobs.append((rule, output, field.group(2)))
            rule = ""
    shown = [(rule, output, reason) for rule, output, reason in jobs
             if rule != "all" and not reason.startswith(FOLLOWS)]
    missing = [job for job in shown if job[2].startswith("Missing output files")]
    out = [f"  {len(missing)} job{'s' if len(missing) != 1 else ''}: outputs not there yet"] if missing else []
    for rule, output, reason in shown:
        if reason.startswith(NEWER_INPUT):
            newer = reason[len(NEWER_INPUT):]
            out.append(f"  {output} ({rule}): its input {newer} is newer than its outputs; Snakemake compares the "
                       "contents only of inputs under 1 MB, so after a copy that did not keep file times (cp -r; cp -a "
                       "keeps them) it reruns")
        elif not reason.startswith("Missing output files"):
            out.append(f"  {output} ({rule}): {reason}")
    return ["", "Why they run:", *out] if out else []


class DryRunView:
    """A dry run: Snakemake's table of jobs per rule; the end of its output when it fails."""

    def __init__(self, out: TextIO, err: TextIO) -> None:
        self.out, self.err = out, err
        self.lines: list[str] = []
        self.stopped: int | None = None

    def feed(self, line: str) -> None:
        self.lines.append(line.rstrip("\r\n"))

    def idle(self) -> None:
        pass

    def close(self, status: int) -> None:
        if self.stopped is not None:
            print("vpr-smr run: interrupted", file=self.err)
        elif status != 0:
            print(*self._tail(), sep="\n", file=self.err)
        elif "Job stats:" in self.lines:
            start = self.lines.index("Job stats:")
            end = next((i for i, line in enumerate(self.lines[start:], start) if TOTAL.fullmatch(line)), start)
            print(*self.lines[start : end + 1], sep="\n", file=self.out)
            print(*why_jobs_run(self.lines), sep="\n", file=self.out)
            print("This was a dry run; `vpr-smr run -n --verbose` lists every job and why it runs.", file=self.out)
        elif any(line.startswith(NOTHING_TO_DO) for line in self.lines):
            print(next(line for line in self.lines if line.startswith(NOTHING_TO_DO)), file=self.out)
        else:  # not a plan of jobs (Snakemake options such as --summary or --list-rules): all of it
            print(*self.lines, sep="\n", file=self.out)

    def _tail(self) -> list[str]:
        return [line for line in self.lines if line.strip()][-TAIL_LINES:]


class ProgressView:
    """Jobs done out of the total, what runs, the time since the start; Snakemake's whole output to ``log``.

    On a terminal one line is redrawn in place, with each running job's fraction done; elsewhere (a CI log, a file)
    one line is added per finished job, and per running job every ``report_s`` seconds with its progress. The
    progress is the last state the job's stage wrote into its log (``core.progress``). ``now``: the clock.
    """

    def __init__(self, log: Path, out: TextIO, err: TextIO, tty: bool | None = None,
                 now: Callable[[], float] = time.monotonic, report_s: float = REPORT_EVERY_S) -> None:
        self.log_path = log
        self.log = open(log, "w", encoding="utf-8")
        self.out, self.err = out, err
        self.tty = out.isatty() if tty is None else tty
        self.parsed = SnakemakeOutput()
        self.tail: deque[str] = deque(maxlen=TAIL_LINES)
        self._now, self.report_s = now, report_s
        self.started = now()
        self.stopped: int | None = None
        self._drawn = ""  # the line redrawn on a terminal
        self._since: dict[str, float] = {}  # jobid -> when it started
        self._reported: dict[str, float] = {}  # jobid -> when its last progress line was printed (not a terminal)
        self._progress: dict[str, Progress | None] = {}  # jobid -> its progress, as last read (terminal)
        self._read_at: float | None = None
        print(f"Snakemake's output: {log}", file=out, flush=True)

    def feed(self, line: str) -> None:
        self.log.write(line)
        self.log.flush()  # a user may follow it with `tail -f`
        if self.stopped is not None:
            return  # what Snakemake prints as it stops (tracebacks of its event loop) is for the log only
        if line.strip():
            self.tail.append(line.rstrip("\r\n"))
        total = self.parsed.total
        self._show(self.parsed.feed(line))
        if total is None and self.parsed.total is not None:
            self._line(f"{self.parsed.total} jobs to run")

    def idle(self) -> None:
        if self.stopped is None:
            self._show(self.parsed.flush())
            if self.tty and self.parsed.total:
                now = self._now()
                if self._read_at is None or now - self._read_at >= READ_EVERY_S:
                    self._read_at = now
                    self._progress = {jobid: job.progress() for jobid, job in self._running_jobs()[:SHOWN_JOBS]}
                self._draw(self._status())
            elif not self.tty:
                self._report()

    def close(self, status: int) -> None:
        self.log.close()
        self._clear()
        parsed = self.parsed
        if self.stopped is not None:
            print(f"vpr-smr run: interrupted; the running jobs were stopped (Snakemake's output: {self.log_path})",
                  file=self.err)
            return
        self._show(parsed.flush())
        self._clear()
        if status == 0:
            if parsed.nothing_to_do:
                print("Nothing to be done: every result is up to date.", file=self.out)
            elif parsed.total is not None:
                print(f"{parsed.done} of {parsed.total} jobs done in {clock(self._elapsed())}", file=self.out)
            else:  # Snakemake options that print instead of running (--summary, --dag) are for --verbose
                print(f"Snakemake ran no job; its output is in {self.log_path} (`vpr-smr run --verbose` shows it)",
                      file=self.out)
            return
        for job in parsed.failed:
            print(*failure_report(job), sep="\n", file=self.err)
        if not parsed.failed:  # Snakemake itself failed (the plan, a missing file): its last words
            print("vpr-smr run: Snakemake failed:", *[f"  {line}" for line in self.tail], sep="\n", file=self.err)
        print(f"vpr-smr run: Snakemake's full output: {self.log_path}", file=self.err)

    def _show(self, events: list[tuple[str, Job]]) -> None:
        for kind, job in events:
            if job.rule == "all":  # the workflow's target, not a job of ours
                continue
            if job.jobid is not None:
                if kind == "started":
                    self._since[job.jobid] = self._reported[job.jobid] = self._now()
                else:
                    for times in (self._since, self._reported):
                        times.pop(job.jobid, None)
            if kind == "failed":
                self._line(f"{self._count()} FAILED {job.label()}")
            elif kind == "done" and not self.tty:
                self._line(f"{self._count()} done {job.label()}{self._running('; running ')}")
            if kind == "done":  # a finished job's warnings stay on the console, on a terminal too
                for warning in job_warnings(job):
                    self._line(f"{self._count()} WARNING {job.label()}: {warning}")
        if events and self.tty:
            self._draw(self._status())

    def _report(self) -> None:
        """A line for each job that has run ``report_s`` seconds since it started or since its last line."""
        now = self._now()
        for jobid, job in self._running_jobs():
            if now - self._reported.setdefault(jobid, now) < self.report_s:
                continue
            self._reported[jobid] = now
            progress = job.progress()
            what = f": {progress_text(progress)}" if progress else f" for {clock(now - self._since.get(jobid, now))}"
            self._line(f"{self._count()} running {job.label()}{what}")

    def _elapsed(self) -> float:
        return self._now() - self.started

    def _running_jobs(self) -> list[tuple[str, Job]]:
        return [(jobid, job) for jobid, job in self.parsed.running.items() if job.rule != "all"]

    def _count(self) -> str:
        total = self.parsed.total or 0
        return f"[{self.parsed.done:>{len(str(total))}}/{total}] {clock(self._elapsed())}"

    def _running(self, prefix: str, most: int = 3, fractions: bool = False) -> str:
        jobs = [job.label() + (self._fraction(jobid) if fractions else "") for jobid, job in self._running_jobs()]
        if not jobs:
            return ""
        more = f" and {len(jobs) - most} more" if len(jobs) > most else ""
        return prefix + ", ".join(jobs[:most]) + more

    def _fraction(self, jobid: str) -> str:
        progress = self._progress.get(jobid)
        if progress is None:
            return ""
        return f" {progress.desc + ' ' if progress.desc else ''}{100 * progress.fraction:.0f} %"

    def _status(self) -> str:
        return f"{self._count()}{self._running(' running ', most=SHOWN_JOBS, fractions=True)}"

    def _line(self, text: str) -> None:
        """A line that stays (above the redrawn one on a terminal)."""
        self._clear()
        print(text, file=self.out, flush=True)

    def _draw(self, text: str) -> None:
        width = shutil.get_terminal_size().columns - 1
        text = text if len(text) <= width else text[: width - 3] + "..."
        if text != self._drawn:
            self.out.write("\r\x1b[K" + text)
            self.out.flush()
            self._drawn = text

    def _clear(self) -> None:
        if self._drawn:
            self.out.write("\r\x1b[K")
            self.out.flush()
            self._drawn = ""


def follow(process: subprocess.Popen[str], view: View, idle_s: float = 0.2, linger_s: float = 2.0) -> int:
    """Hand each line ``process`` prints to ``view`` until it ends; its exit status.

    The lines are read by a thread, so that the view is redrawn while Snakemake is silent. The pipe may outlive
    Snakemake (a job it started still holding it): reading stops ``linger_s`` after Snakemake exits.
    """
    lines: queue.Queue[str | None] = queue.Queue()

    def read() -> None:
        assert process.stdout is not None  # started with stdout=PIPE (workflow._snakemake)
        for line in process.stdout:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()
    exited_at = None
    while True:
        try:
            line = lines.get(timeout=idle_s)
        except queue.Empty:
            view.idle()
            if exited_at is None and process.poll() is not None:
                exited_at = time.monotonic()
            if exited_at is not None and time.monotonic() - exited_at > linger_s:
                break
            continue
        if line is None:
            break
        view.feed(line)
    status = process.wait()
    view.close(status)
    return status
