"""The declared layering holds: each stage imports only the stages below it (pyproject's [tool.importlinter]), over
the whole package as the checkout holds it (vpr_smr/ and the stage folders behind its links)."""

import re
import subprocess
import sys
from pathlib import Path

from helpers import REPO

STAGE_FOLDERS = ("core", "data", "datasets", "descriptors", "eval", "pipeline")


def test_import_contract_is_kept_over_every_module():
    # lint-imports reads every import, lazy ones inside functions too; --no-cache leaves no cache in the checkout.
    lint = Path(sys.executable).with_name("lint-imports")
    result = subprocess.run([str(lint), "--no-cache"], cwd=REPO, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "0 broken" in result.stdout
    # every module of the package was read: the links followed (a contract over vpr_smr/*.py alone would hold too)
    modules = [*(REPO / "vpr_smr").glob("*.py")]
    for folder in STAGE_FOLDERS:
        modules += [path for path in (REPO / folder).rglob("*.py") if "__pycache__" not in path.parts]
    analyzed = re.search(r"Analyzed (\d+) files", result.stdout)
    assert analyzed is not None and int(analyzed.group(1)) == len(modules)
