"""Every command and code block of the README and the docs runs in a test: each fenced block carries a marker
(``<!-- NAME -->`` on the line above) that a test reads with ``helpers.doc_block("NAME")`` and runs or checks,
or its page is run whole by the test named here (``WHOLE_PAGES``). A block without one, or a marker no test reads,
fails."""

from __future__ import annotations

import re

from helpers import DOC_MARKER, DOC_PAGES, REPO

# Pages whose every block one test runs, in order (helpers.doc_page_blocks): the page -> that test.
WHOLE_PAGES = {"extending.md": "tests/unit/test_extending.py", "python-api.md": "tests/unit/test_python_api_page.py"}
FENCE = re.compile(r"^(`{3,})([^`\n]*)\n(.*?)^\1[ \t]*$", re.S | re.M)
MARKER = re.compile(DOC_MARKER.format(name="[a-z0-9][a-z0-9-]*") + "$")


def blocks() -> list[tuple[str, str, str | None]]:
    """Every fenced code block as (page, its first line, its marker or None); MyST directives (```{toctree}) are
    no code blocks."""
    found = []
    for page in DOC_PAGES:
        text = page.read_text()
        for match in FENCE.finditer(text):
            if match.group(2).strip().startswith("{"):
                continue
            line_above = text[:match.start()].rsplit("\n", 2)[-2:]
            marker = MARKER.search("\n".join(line_above))
            first = match.group(3).splitlines()[0] if match.group(3).strip() else "(empty)"
            found.append((page.name, first, marker.group(1) if marker else None))
    return found


def test_the_blocks_are_found():
    """The scan sees the blocks it must (the README's two commands, an extending recipe), so the checks below
    cannot pass by finding nothing."""
    found = blocks()
    assert any(page == "README.md" and first.startswith("make demo") for page, first, _ in found)
    assert any(page == "extending.md" for page, _, _ in found)


def test_every_block_has_a_marker_or_a_test_that_runs_its_page():
    missing = [f"{page}: {first}" for page, first, marker in blocks() if marker is None and page not in WHOLE_PAGES]
    assert not missing, "blocks without a <!-- NAME --> marker above them (and a test reading doc_block(NAME)):\n" + \
        "\n".join(missing)


def test_every_marker_names_one_block():
    names = [marker for _, _, marker in blocks() if marker]
    twice = sorted({name for name in names if names.count(name) > 1})
    assert not twice, f"markers on more than one block: {twice}"


def test_every_marked_block_is_read_by_a_test():
    tests = "\n".join(path.read_text() for path in (REPO / "tests").rglob("*.py"))
    read = set(re.findall(r"doc_block\(\s*\"([a-z0-9-]+)\"", tests))
    unread = sorted({f"{page}: {marker}" for page, _, marker in blocks() if marker and marker not in read})
    assert not unread, "marked blocks no test reads with doc_block(...):\n" + "\n".join(unread)


def test_the_pages_run_whole_are_run_by_their_test():
    for page, test in WHOLE_PAGES.items():
        assert (REPO / "docs" / page).is_file(), page
        assert f'"{page}"' in (REPO / test).read_text(), f"{test} does not read docs/{page}"
