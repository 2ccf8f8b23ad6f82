"""Where a workflow run's time went, from its Snakemake log (``results/<run>/logs/snakemake-*.log``): per rule the
jobs, the sum, mean and longest of their wall times, and how busy the cores were (a job counts its ``threads``, 1
where the log names none). Snakemake stamps the log to the second, so a job's time is whole seconds. Several logs
print side by side (a run before and after a change; compare runs of one machine at one time of day only: a job's
wall time grows with whatever else runs on the cores).

    python benchmarks/demo_jobs.py results/demo/logs/snakemake-*.log
    python benchmarks/demo_jobs.py before/results/demo/logs/snakemake-1.log results/demo/logs/snakemake-2.log
"""

from __future__ import annotations

import argparse
import re
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

STAMP = re.compile(r"\[(\w{3} \w{3} +\d+ [\d:]+ \d{4})\]")
RULE = re.compile(r"\s*(?:local)?rule (\w+):")
JOB = re.compile(r"\s*jobid: (\d+)")
THREADS = re.compile(r"\s*threads: (\d+)")
FINISHED = re.compile(r"Finished jobid: (\d+)")


@dataclass
class Job:
    rule: str
    start: datetime
    threads: int = 1
    end: datetime | None = None

    @property
    def seconds(self) -> float:
        return 0.0 if self.end is None else (self.end - self.start).total_seconds()


def read_jobs(path: Path) -> list[Job]:
    """The finished jobs of a Snakemake log: a job starts at the stamp above its ``rule`` line and ends at the stamp
    above its ``Finished jobid`` line."""
    stamp: datetime | None = None
    rule: str | None = None
    current: Job | None = None
    jobs: dict[int, Job] = {}
    for line in path.read_text(errors="replace").splitlines():
        if match := STAMP.match(line):
            stamp = datetime.strptime(match.group(1), "%a %b %d %H:%M:%S %Y")
        elif match := RULE.match(line):
            rule, current = match.group(1), None
        elif (match := JOB.match(line)) and rule is not None and stamp is not None:
            current = jobs[int(match.group(1))] = Job(rule, stamp)
        elif (match := THREADS.match(line)) and current is not None:
            current.threads = int(match.group(1))
        elif (match := FINISHED.match(line)) and stamp is not None and int(match.group(1)) in jobs:
            jobs[int(match.group(1))].end = stamp
    return [job for job in jobs.values() if job.end is not None]


def summary(jobs: list[Job], cores: int) -> tuple[dict[str, tuple[int, float, float]], float, float]:
    """Per rule (jobs, sum of seconds, longest), the run's wall seconds, and the core-seconds its jobs kept busy
    (at most ``cores`` at a time)."""
    rules: dict[str, tuple[int, float, float]] = {}
    for job in jobs:
        n, total, longest = rules.get(job.rule, (0, 0.0, 0.0))
        rules[job.rule] = (n + 1, total + job.seconds, max(longest, job.seconds))
    if not jobs:
        return rules, 0.0, 0.0
    first = min(job.start for job in jobs)
    wall = max((job.end - first).total_seconds() for job in jobs if job.end is not None)
    busy = [0] * (int(wall) + 1)
    for job in jobs:
        start = int((job.start - first).total_seconds())
        for second in range(start, max(start + 1, int(start + job.seconds))):
            busy[second] += job.threads
    return rules, wall, float(sum(min(used, cores) for used in busy))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("logs", type=Path, nargs="+", help="Snakemake logs of runs (results/<run>/logs/)")
    parser.add_argument("--cores", type=int, default=2, help="the cores the runs had (the demo's profile: 2)")
    args = parser.parse_args()
    runs = [summary(read_jobs(path), args.cores) for path in args.logs]
    names = sorted({rule for rules, _, _ in runs for rule in rules},
                   key=lambda rule: -max(rules.get(rule, (0, 0.0, 0.0))[1] for rules, _, _ in runs))
    print("rule: jobs, sum / longest job (s), per log: " + " | ".join(path.name for path in args.logs))
    for rule in names:
        cells = []
        for rules, _, _ in runs:
            n, total, longest = rules.get(rule, (0, 0.0, 0.0))
            cells.append(f"{n:3d} {total:6.0f} / {longest:4.0f}")
        print(f"{rule:20s} " + " | ".join(cells))
    for path, (rules, wall, busy) in zip(args.logs, runs, strict=True):
        jobs_s = sum(total for _, total, _ in rules.values())
        print(f"{path}: {sum(n for n, _, _ in rules.values())} jobs, wall {wall:.0f} s, job time {jobs_s:.0f} s, "
              f"cores busy {busy:.0f} of {args.cores * wall:.0f} core-seconds")


if __name__ == "__main__":
    main()
