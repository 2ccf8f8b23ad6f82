"""What declaring the stages imports: every `vpr-smr` command (and every workflow job) installs every stage, so the
job records live in light modules (`eval.scoring.study_jobs`, `eval.report.job`) and the work's modules are imported
when their stage runs."""

from __future__ import annotations

import subprocess
import sys

WORK = ("vpr_smr.eval.scoring.speed", "vpr_smr.eval.scoring.adaptive", "vpr_smr.eval.scoring.matcher_comparison",
        "vpr_smr.eval.report.inspector", "vpr_smr.eval.report.figures")


def test_the_stage_declarations_and_the_configuration_leave_the_work_modules_out():
    code = ("import sys\nimport vpr_smr.pipeline.stages, vpr_smr.pipeline.config\n"
            f"print(' '.join(m for m in {WORK!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == ""


def test_the_job_records_are_importable_where_they_were():
    from vpr_smr.eval.report import inspector, job
    from vpr_smr.eval.scoring import adaptive, matcher_comparison, speed, study_jobs

    assert speed.SpeedJob is study_jobs.SpeedJob and speed.SpeedExperiment is study_jobs.SpeedExperiment
    assert matcher_comparison.MatchersJob is study_jobs.MatchersJob
    assert matcher_comparison.ComparedInputs is study_jobs.ComparedInputs
    assert adaptive.AdaptiveJob is study_jobs.AdaptiveJob
    assert inspector.InspectJob is job.InspectJob
