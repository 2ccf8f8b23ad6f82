"""The declared layering holds: each stage imports only the stages below it (pyproject's [tool.importlinter])."""

import subprocess
import sys
from pathlib import Path

from helpers import REPO


def test_import_contract_is_kept():
    # lint-imports reads every import, lazy ones inside functions too; --no-cache leaves no cache in the checkout.
    lint = Path(sys.executable).with_name("lint-imports")
    result = subprocess.run([str(lint), "--no-cache"], cwd=REPO, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "0 broken" in result.stdout
