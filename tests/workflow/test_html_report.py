"""report.html in a real browser: Debian's headless ``chromium`` (installed with apt-get when missing; the test fails
with the reason when it cannot be installed, it is never skipped), driven by Playwright for Python, offline.

At 1400 x 900: the first screen shows the verdict table with the methods as rows; nothing is wider than the page
(the tables' own scroll containers fit it); a click on a column header sorts the rows; every image decodes; the page
works alone in a fresh folder, and a screenshot of its first screen is a PNG. At 1000, 1400 and 1920 px, with the
demo's method names (one as long as efficientnet_lite0_gem): no table or figure is cut at the right edge.
"""

import csv
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from report_runs import build_run

CHROMIUM = "/usr/bin/chromium"
# Debian's browser, never a downloaded one; nothing reaches the network.
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage"]
WIDTH, HEIGHT = 1400, 900

# Every element's right edge, but inside a scroll container the page made on purpose (class "scroll"), which
# must fit itself; the document's own width.
OVERFLOW = """() => {
  const limit = window.innerWidth + 1, wide = [];
  for (const el of document.querySelectorAll("body *")) {
    if (el.parentElement && el.parentElement.closest(".scroll")) continue;
    const right = el.getBoundingClientRect().right;
    if (right > limit) wide.push(`${el.tagName.toLowerCase()}.${el.className} ends at ${right}`);
  }
  return {scrollWidth: document.documentElement.scrollWidth, innerWidth: window.innerWidth, wide: wide,
          scrolls: document.querySelectorAll(".scroll").length};
}"""
# Each table's and image's right edge against what of it can be seen: the viewport without its scroll bar and every
# ancestor that clips (overflow-x other than visible); and whether the nearest such ancestor scrolls sideways
# (a scroll bar shows what it hides) and ends within the viewport.
VISIBLE = """() => {
  const viewport = document.documentElement.clientWidth, found = [];
  for (const el of [...document.querySelectorAll("table"), ...document.images]) {
    const box = el.getBoundingClientRect();
    let visible = viewport, scroller = null;
    for (let up = el.parentElement; up && up !== document.documentElement; up = up.parentElement) {
      const style = getComputedStyle(up);
      if (style.overflowX === "visible") continue;
      const outer = up.getBoundingClientRect();
      visible = Math.min(visible, outer.left + up.clientLeft + up.clientWidth);
      if (scroller === null) {
        scroller = {scrolls: ["auto", "scroll"].includes(style.overflowX) && up.scrollWidth > up.clientWidth,
                    right: outer.right};
      }
    }
    found.push({what: `${el.tagName.toLowerCase()}#${el.id || el.alt}`, left: box.left, right: box.right,
                width: box.width, visible: visible, viewport: viewport, beside: el.closest(".pair") !== null,
                scrolls: scroller !== null && scroller.scrolls, scroller_right: scroller ? scroller.right : null});
  }
  return {found: found, scrollWidth: document.documentElement.scrollWidth, viewport: viewport};
}"""
IMAGES = """() => Array.from(document.images).map(img => ({complete: img.complete, width: img.naturalWidth,
                                                        alt: img.alt}))"""


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


def sort_values(page, table: str, column: int) -> list[float | None]:
    """The numbers of one column of a table, in the rows' order (None for an empty or n/a cell)."""
    cells = page.eval_on_selector_all(
        f"#{table} tbody tr", f"rows => rows.map(r => r.cells[{column}].getAttribute('data-sort'))")
    return [float(v) if v else None for v in cells]


@pytest.mark.slow
def test_report_in_a_headless_browser(tmp_path):
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.fail("playwright is not installed: pip install -e '.[dev]' (it drives Debian's chromium; no browser "
                    "download, never `playwright install`)")

    run, written = build_run(tmp_path, modes=("paper", "standard"), seq_lens=(2, 4), methods=("m2", "m1"))
    text = (run / "report.html").read_text()
    n_figures = len(list((run / "figures").iterdir()))  # the report's figures and the inspector's it was given
    assert n_figures >= 15 and text.count("<img ") == n_figures
    # self-contained: no network address and no file the page would load besides itself
    assert not re.search(r"(src|href)=\"(?!data:image/png;base64,|#)", text)
    assert "http://" not in text and "https://" not in text and "<link" not in text
    assert "ab" * 32 in text and "cd" * 32 in text and "seq_lens: [2, 4]" in text  # provenance and config
    for path in written:  # every table is named in the page by its files
        if path.suffix == ".csv":
            assert f"tables/{path.name}" in text

    alone = tmp_path / "alone"
    alone.mkdir()
    shutil.copy(run / "report.html", alone / "report.html")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=ensure_chromium(), args=ARGS)
        try:
            page = browser.new_page(viewport={"width": WIDTH, "height": HEIGHT})
            page.route(re.compile(r"^(?!file:|data:).*"), lambda route: route.abort())  # offline, whatever it asks
            page.goto((alone / "report.html").as_uri(), wait_until="load")

            # the first screen: the verdict table, standard mode, the methods as its rows in the configuration's
            # order, a column per question the run asked (no matcher or length rule here), whole on the screen
            verdicts = page.locator("table.verdicts").first
            assert verdicts.get_attribute("id") == "verdicts-d-standard"
            assert [h.strip() for h in verdicts.locator("thead th").all_inner_texts()] == [
                "method", "reduces the AOC?", "beats the best training-free rule?", "detects wrong matches better?"]
            assert [h.strip() for h in verdicts.locator("tbody th").all_inner_texts()] == ["m2", "m1"]
            box = verdicts.bounding_box()
            assert box is not None and box["y"] < HEIGHT and box["y"] + box["height"] <= HEIGHT, box
            assert page.locator("#findings .verdict-block h3").first.inner_text().startswith(
                "d · 57 test queries; correct within 2 frames")
            # the paper mode folded below it, then one sentence per finding, then Table I
            assert page.locator("#findings details.verdict-mode summary").inner_text() == "The same in paper mode"
            assert page.locator("#findings ul.headlines li").first.inner_text().startswith("d (")
            assert "L = 4, paper mode): the seed-0 predictor's AOC reduction with its 95 % interval is" in (
                page.locator("#findings ul.headlines li").first.inner_text())
            table1 = page.locator("table.table1").first
            assert [h.strip() for h in table1.locator("thead th").all_inner_texts()] == [
                "", "m2", "m1", "Mean", "Improved"]
            shot = tmp_path / "first_screen.png"
            page.screenshot(path=str(shot))
            assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 10_000

            # every image decodes
            images = page.evaluate(IMAGES)
            assert len(images) == n_figures and all(i["complete"] and i["width"] > 0 for i in images), images

            # nothing is wider than the page, the folded tables opened too
            for summary in page.locator("details > summary").all():
                summary.click()
            layout = page.evaluate(OVERFLOW)
            assert layout["scrollWidth"] <= layout["innerWidth"] == WIDTH and not layout["wide"], layout
            assert layout["scrolls"] > 10

            # a click on a column header sorts the rows by that column's numbers: up, then down
            rows = list(csv.DictReader(open(run / "tables" / "trust_levels.csv")))
            column = list(rows[0]).index("auc")
            values = [float(r["auc"]) if r["auc"] else None for r in rows]
            assert sort_values(page, "all-trust_levels", column) == values  # the CSV's order first
            header = page.locator("#all-trust_levels thead th").nth(column)
            header.click()
            numbers = sorted(v for v in values if v is not None)
            blanks = [None] * values.count(None)
            assert sort_values(page, "all-trust_levels", column) == numbers + blanks
            assert numbers + blanks != values and header.get_attribute("aria-sort") == "ascending"
            header.click()
            assert sort_values(page, "all-trust_levels", column) == numbers[::-1] + blanks
            # text columns sort too (natural order), and the sorted rows keep their cells together
            method = page.locator("#all-trust_levels thead th").nth(list(rows[0]).index("method"))
            method.click()
            shown = page.eval_on_selector_all("#all-trust_levels tbody tr",
                                              "rows => rows.map(r => [r.cells[1].textContent, r.cells[4].textContent])")
            assert [m for m, _ in shown] == sorted(r["method"] for r in rows)
            assert sorted(shown) == sorted([r["method"], f"{float(r['trust']):g}"] for r in rows)
        finally:
            browser.close()


def cut(item: dict) -> bool:
    """Whether some of a table or image is hidden at the right without a scroll bar to reach it. A whole table may
    scroll in its own box (which must itself fit); a table beside a figure, or a figure, must be seen whole: a
    scroll box there hid the restoration table's last column."""
    if item["right"] <= item["visible"] + 1 and item["left"] >= -1:
        return False
    may_scroll = item["what"].startswith("table") and not item["beside"]
    return not (may_scroll and item["scrolls"] and item["scroller_right"] <= item["viewport"] + 1)


@pytest.mark.slow
def test_no_table_or_figure_is_cut_at_any_width(tmp_path):
    from playwright.sync_api import sync_playwright

    # the demo's methods: a long name widens every compact table beside its figure
    run, _ = build_run(tmp_path, modes=("paper",), seq_lens=(4,), methods=("sad", "hog", "efficientnet_lite0_gem"))
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=ensure_chromium(), args=ARGS)
        try:
            for width in (1000, 1400, 1920):
                page = browser.new_page(viewport={"width": width, "height": HEIGHT})
                page.route(re.compile(r"^(?!file:|data:).*"), lambda route: route.abort())
                page.goto((run / "report.html").as_uri(), wait_until="load")
                for summary in page.locator("details > summary").all():
                    summary.click()  # the whole tables too, the widest ones
                layout = page.evaluate(VISIBLE)
                found = layout["found"]
                tables = [f for f in found if f["what"].startswith("table")]
                assert len(tables) > 15 and all(f["width"] > 0 for f in found), (width, found)
                assert sum(f["beside"] for f in tables) >= 5  # the compact tables of the figures' blocks
                assert {f["what"] for f in tables} >= {"table#restoration-d-4-paper"}
                assert layout["scrollWidth"] <= layout["viewport"] <= width, (width, layout["scrollWidth"])
                hidden = [f for f in found if cut(f)]
                assert not hidden, (width, hidden)
                page.close()
        finally:
            browser.close()
