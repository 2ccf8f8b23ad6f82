"""What the workflow's parsing imports: every `vpr-smr run` (a no-op one included) reads the Snakefile, whose
rules import these modules; scikit-learn (about 1 s), SciPy's statistics and PyTorch must not come with them."""

from __future__ import annotations

import subprocess
import sys

PARSING = ("vpr_smr.core.constants", "vpr_smr.core.paths", "vpr_smr.descriptors", "vpr_smr.eval.predictor.defaults",
           "vpr_smr.pipeline.config", "vpr_smr.pipeline.options", "vpr_smr.pipeline.plan",
           "vpr_smr.pipeline.rule_helpers", "vpr_smr.eval.scoring.speed", "vpr_smr.eval.report.registry")
HEAVY = ("sklearn", "scipy.stats", "torch")


def test_the_modules_the_rules_import_leave_the_heavy_libraries_out():
    code = (f"import importlib, sys\nfor name in {PARSING!r}:\n    importlib.import_module(name)\n"
            f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == ""
