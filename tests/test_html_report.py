"""report.html is one self-contained page that a real browser renders with every figure.

The page is opened in Debian's headless ``chromium`` (installed with apt-get when missing; the test fails with the
reason when it cannot be installed, it is never skipped): a copy of the page with a small script appended writes
every image's natural width into the DOM, which ``--dump-dom`` prints; ``--screenshot`` must give a PNG.
"""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from test_report import build_run

CHROMIUM = "/usr/bin/chromium"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage", "--virtual-time-budget=10000"]
PROBE = """
<script>
window.addEventListener("load", () => {
  const widths = Array.from(document.images).map(img => img.complete ? img.naturalWidth : -1);
  const out = document.createElement("pre");
  out.id = "probe";
  out.textContent = "WIDTHS=" + widths.join(",") + ";";
  document.body.appendChild(out);
});
</script>
"""


def ensure_chromium() -> str:
    if Path(CHROMIUM).is_file():
        return CHROMIUM
    if os.geteuid() != 0:
        pytest.fail(f"{CHROMIUM} is missing and the test is not root, so it cannot apt-get install chromium; "
                    "install Debian's chromium package")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for command in (["apt-get", "update"], ["apt-get", "install", "-y", "chromium"]):
        done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=900)
        if done.returncode != 0:
            pytest.fail(f"{' '.join(command)} failed ({done.returncode}): {done.stderr[-2000:]}")
    if not Path(CHROMIUM).is_file():
        pytest.fail(f"apt-get install chromium finished but {CHROMIUM} does not exist")
    return CHROMIUM


def chromium(args: list[str], profile: Path) -> subprocess.CompletedProcess:
    return subprocess.run([ensure_chromium(), *FLAGS, f"--user-data-dir={profile}", *args],
                          capture_output=True, text=True, timeout=180)


@pytest.mark.slow
def test_report_renders_every_figure_in_a_headless_browser(tmp_path):
    run, written = build_run(tmp_path, modes=("paper",), seq_lens=(4,))
    page = run / "report.html"
    text = page.read_text()
    n_figures = len([p for p in written if p.suffix == ".png"])
    assert n_figures >= 5 and text.count("<img ") == n_figures
    # self-contained: no network address and no file the page would load besides itself
    assert not re.search(r"(src|href)=\"(?!data:image/png;base64,|#)", text)
    assert "http://" not in text and "https://" not in text
    assert "ab" * 32 in text and "cd" * 32 in text and "seq_lens: [2, 4]" in text  # provenance and config
    for name in ("table1.csv", "table2.csv", "restoration.csv", "leave_one_method_out.csv", "timing.csv"):
        assert name in text

    # the page moved alone to a fresh folder still renders every image
    alone = tmp_path / "alone"
    alone.mkdir()
    probe = alone / "probe.html"
    probe.write_text(text.replace("</body>", PROBE + "</body>"))
    done = chromium(["--dump-dom", probe.as_uri()], tmp_path / "profile1")
    found = re.search(r"WIDTHS=([-0-9,]*);", done.stdout)
    assert found, f"chromium printed no probe result: {done.stderr[-2000:]}"
    widths = [int(w) for w in found.group(1).split(",") if w]
    assert len(widths) == n_figures and min(widths) > 0, widths

    shutil.copy(page, alone / "report.html")
    shot = tmp_path / "shot.png"
    done = chromium([f"--screenshot={shot}", "--window-size=1400,4000", (alone / "report.html").as_uri()],
                    tmp_path / "profile2")
    assert shot.is_file() and shot.stat().st_size > 10_000, done.stderr[-2000:]
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_provenance_of_descriptor_files_and_tables_in_the_page(tmp_path):
    import base64

    from vpr_smr.core.io import atomic_h5
    from vpr_smr.eval.report.html import main

    descriptors = tmp_path / "hog.h5"
    with atomic_h5(descriptors, {"dataset": "toy", "method": "hog", "checkpoint_sha256": "11" * 32,
                                 "frames_sha256": "22" * 32}):
        pass
    (tmp_path / "t.csv").write_text("method,reduction_pct\nhog,12.345678\n")
    png = base64.b64decode("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9aw"
                           "AAAABJRU5ErkJggg==")  # a 1 x 1 PNG
    (tmp_path / "f.png").write_bytes(png)
    page = main(tmp_path / "report.html", [("Table I", tmp_path / "t.csv")], [("a figure", tmp_path / "f.png")],
                config={"run": "toy", "seq_lens": [4]}, provenance={"vpr_smr_version": "9.9"},
                descriptor_paths=[descriptors]).read_text()
    assert "11" * 32 in page and "22" * 32 in page and "<td class=\"text\">hog</td>" in page
    assert "<td>12.3457</td>" in page  # floats to 4 decimals
    assert 'src="data:image/png;base64,iVBORw0KGgo' in page
    assert "run: toy" in page and "9.9" in page
    # The version to cite is the one that made the results (the run's provenance), not the installed one.
    assert 'vpr-smr: sequence-matching receptiveness for visual place recognition&quot;, version 9.9' in page
    assert "Hussaini, T. Fischer and M. Milford" in page
