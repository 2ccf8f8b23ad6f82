"""The documentation site: it builds offline with every warning an error (as ``make docs`` does), its pages load
nothing from outside, every internal link of the site and of the README resolves, and the README stays short and
leads a new user to the two tasks the issue named in one click each."""

from __future__ import annotations

import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
from helpers import REPO

DOCS = REPO / "docs"
README = REPO / "README.md"
# Attributes through which a page loads something (a link's href is a resource only for these rel values).
LOADING = {("script", "src"), ("img", "src"), ("iframe", "src"), ("source", "src"), ("video", "src"),
           ("audio", "src"), ("embed", "src"), ("object", "data"), ("image", "href")}
LOADING_LINKS = {"stylesheet", "icon", "preload", "prefetch", "modulepreload", "manifest", "apple-touch-icon"}
MARKDOWN_LINK = re.compile(r"!?\[([^\]]*)\]\(([^)\s]+)\)")


class Page(HTMLParser):
    """One built page's ids, links (a href) and loaded resources (with the tag that loads each)."""

    def __init__(self) -> None:
        super().__init__()
        self.ids: set[str] = set()
        self.links: list[str] = []
        self.loads: list[str] = []
        self.styles: list[str] = []
        self._in_style = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = {name: value or "" for name, value in attrs}
        if "id" in values:
            self.ids.add(values["id"])
        if tag == "a" and "name" in values:
            self.ids.add(values["name"])
        if tag == "a" and "href" in values:
            self.links.append(values["href"])
        if tag == "link" and LOADING_LINKS & set(values.get("rel", "").split()):
            self.loads.append(values.get("href", ""))
        self.loads += [values[name] for t, name in LOADING if t == tag and name in values]
        if "style" in values:
            self.styles.append(values["style"])
        self._in_style = tag == "style"

    def handle_data(self, data: str) -> None:
        if self._in_style:
            self.styles.append(data)


def parse(path: Path) -> Page:
    page = Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site built as ``make docs`` builds it (warnings as errors, nitpicky), from the docs in the checkout."""
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run([sys.executable, "-m", "sphinx", "--quiet", "--fail-on-warning", "--keep-going",
                           "--nitpicky", "--builder", "html", str(DOCS), str(out)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"the docs site does not build cleanly:\n{done.stdout}\n{done.stderr}"
    assert not done.stderr.strip(), f"the build warned:\n{done.stderr}"
    return out


def pages(site: Path) -> dict[Path, Page]:
    return {path: parse(path) for path in sorted(site.rglob("*.html"))}


def outside(url: str) -> bool:
    """Whether ``url`` is fetched from elsewhere than the site (a scheme or a protocol-relative //host)."""
    parts = urlsplit(url.strip())
    return bool(parts.scheme and parts.scheme != "data" or parts.netloc)


def test_the_makefile_and_ci_build_the_site_as_this_test_does():
    makefile = (REPO / "Makefile").read_text()
    assert re.search(r"^docs: .*\n\t\$\(BIN\)/sphinx-build --quiet --fail-on-warning --keep-going --nitpicky "
                     r"--builder html docs docs/_build/html$", makefile, re.M)
    assert "make docs" in (REPO / ".ci" / "run").read_text().split("set -euo pipefail")[1]


def test_every_page_of_the_docs_folder_is_in_the_site(site):
    built = {path.relative_to(site).with_suffix("").as_posix() for path in site.rglob("*.html")}
    written = {path.relative_to(DOCS).with_suffix("").as_posix() for path in DOCS.glob("*.md")}
    assert written <= built, f"pages not in the site: {sorted(written - built)}"


def test_the_pages_load_nothing_from_outside(site):
    found = []
    for path, page in pages(site).items():
        found += [f"{path.name}: {url}" for url in page.loads if outside(url)]
        for style in page.styles:
            found += [f"{path.name}: {url}" for url in re.findall(r"url\(\s*['\"]?([^'\")]+)", style)
                      if outside(url)]
    for sheet in site.rglob("*.css"):
        text = sheet.read_text(encoding="utf-8")
        found += [f"{sheet.name}: {url}" for url in re.findall(r"url\(\s*['\"]?([^'\")]+)", text) if outside(url)]
        found += [f"{sheet.name}: {line}" for line in re.findall(r"@import[^;]*", text)
                  if re.search(r"https?:|//", line)]
    for script in site.rglob("*.js"):
        found += [f"{script.name}: {url}" for url in re.findall(r"https?://[^\s'\"`)]+",
                                                               script.read_text(encoding="utf-8"))
                  if "w3.org" not in url and re.search(r"\.(js|css|woff2?|ttf|png|svg|json)\b", url)]
    assert not found, "the site loads from outside:\n" + "\n".join(found)


def test_every_internal_link_of_the_site_resolves(site):
    built = pages(site)
    broken = []
    for path, page in built.items():
        for href in page.links:
            if outside(href) or href.startswith("mailto:"):
                continue
            parts = urlsplit(href)
            target = (path.parent / unquote(parts.path)).resolve() if parts.path else path
            if target.is_dir():
                target = target / "index.html"
            if not target.is_file():
                broken.append(f"{path.relative_to(site)}: {href} (no file)")
            elif parts.fragment and target.suffix == ".html" and \
                    unquote(parts.fragment) not in (built.get(target) or parse(target)).ids:
                broken.append(f"{path.relative_to(site)}: {href} (no #{parts.fragment} there)")
    assert not broken, "broken links:\n" + "\n".join(broken)


def readme_links() -> list[tuple[str, str]]:
    return [(text, target) for text, target in MARKDOWN_LINK.findall(README.read_text())]


def github_slug(heading: str) -> str:
    """A heading's anchor as GitHub writes it (and MyST, ``myst_heading_anchors``): lower case, every character but
    letters, digits, spaces, hyphens and underscores dropped, each space a hyphen."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def sections(page: Path) -> dict[str, str]:
    """Each heading's section of ``page`` (levels 1-4; up to the next heading of the same or a higher level), by
    the heading's anchor, fenced blocks included."""
    text = page.read_text()
    # fenced blocks blanked out, keeping every position (a "# comment" in a block is no heading)
    text_without_fences = re.sub(r"^```.*?^```", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text, flags=re.S | re.M)
    headings = [(m.start(), len(m.group(1)), m.group(2))
                for m in re.finditer(r"^(#{1,4}) (.+)$", text_without_fences, re.M)]
    found = {}
    for i, (start, level, title) in enumerate(headings):
        end = next((s for s, lv, _ in headings[i + 1:] if lv <= level), len(text))
        found[github_slug(title.replace("`", ""))] = text[start:end]
    return found


def test_every_link_of_the_readme_resolves():
    broken = []
    for _, target in readme_links():
        if outside(target):
            continue
        parts = urlsplit(target)
        path = REPO / unquote(parts.path)
        if not path.exists():
            broken.append(f"{target} (no file)")
        elif parts.fragment and parts.fragment not in sections(path):
            broken.append(f"{target} (no heading #{parts.fragment} in {parts.path})")
    assert not broken, "README.md links that do not resolve:\n" + "\n".join(broken)


def test_the_readme_is_short_and_links_every_page():
    lines = README.read_text().splitlines()
    assert len(lines) <= 250, f"README.md has {len(lines)} lines (at most 250: reference material goes to docs/)"
    linked = {urlsplit(target).path for _, target in readme_links()}
    pages_ = {f"docs/{path.name}" for path in DOCS.glob("*.md") if path.name != "index.md"}
    assert pages_ <= linked, f"pages the README does not link: {sorted(pages_ - linked)}"


@pytest.mark.parametrize(("task", "words"), [
    ("score a MATLAB .mat similarity matrix with a GThard ground truth", (".mat", "GThard", "--similarity")),
    ("add a matcher", ("vpr_smr.matchers", "class ", "Matcher")),
])
def test_a_new_user_reaches_each_task_in_one_click_from_the_readme(task, words):
    """The README links straight to the section that shows how (one click; the issue allows two)."""
    found = [target for _, target in readme_links()
             if urlsplit(target).path.startswith("docs/") and urlsplit(target).fragment
             and all(word in sections(REPO / urlsplit(target).path).get(urlsplit(target).fragment, "")
                     for word in words)]
    assert found, f"no README link leads to a section that shows how to {task} (with {words})"


class ProseText(HTMLParser):
    """A page's text outside code (``code``, ``pre``, ``kbd``, ``samp``) and scripts and styles: what a reader sees
    as prose and maths, each piece with the tag it sits in."""

    SKIPPED = {"code", "pre", "kbd", "samp", "script", "style"}

    def __init__(self) -> None:
        super().__init__()
        self.pieces: list[tuple[str, str]] = []
        self._open: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag not in {"br", "img", "hr", "meta", "link", "input", "mspace", "mprescripts", "none"}:
            self._open.append(tag)

    def handle_startendtag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        pass

    def handle_endtag(self, tag: str) -> None:
        if tag in self._open:
            while self._open.pop() != tag:
                pass

    def handle_data(self, data: str) -> None:
        if not self.SKIPPED & set(self._open):
            self.pieces.append((self._open[-1] if self._open else "", data))


# A TeX command (a backslash and letters, or an escaped _ { } $ % & #) left in a built page: a formula the MathML
# converter did not understand, or one that Markdown broke.
TEX_COMMAND = re.compile(r"\\(?:[A-Za-z]+|[_{}$%&#])")


def test_the_pages_show_no_tex_command_outside_code(site):
    """Every formula is drawn: no page holds a TeX command (``\\arg``, ``\\_``, a display broken by its list item)
    in its prose or maths, only inside code."""
    left = {}
    for path in sorted(site.rglob("*.html")):
        if "_static" in path.parts or "_sources" in path.parts:
            continue
        text = ProseText()
        text.feed(path.read_text(encoding="utf-8"))
        found = [f"{tag}: {data.strip()[:80]}" for tag, data in text.pieces if TEX_COMMAND.search(data)]
        if found:
            left[path.relative_to(site).as_posix()] = found
    assert left == {}


def test_the_tex_check_sees_a_formula_the_converter_leaves_raw():
    """The check above would see the issue's case: latex2mathml writes ``\\arg`` as it is."""
    from latex2mathml.converter import convert

    text = ProseText()
    formula, step = convert(r"\arg\min_r D[r, a]"), convert(r"\text{max\_step}")
    text.feed(f"<p>the match {formula}, {step} and <code>\\not_this</code></p>")
    assert [data for _, data in text.pieces if TEX_COMMAND.search(data)] == ["\\arg", "max\\_step"]
