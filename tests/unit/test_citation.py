"""The package can be cited: CITATION.cff is valid CFF 1.2.0, cites the SMR paper as the paper names it, and carries
the one version (the package metadata's) that `vpr-smr --version`, the changelog and the report show."""

import json
import re
import subprocess
import sys
import tomllib
from importlib.metadata import version

import jsonschema
import yaml
from helpers import REPO

from vpr_smr.core.citation import PAPER, how_to_cite

CITATION = yaml.safe_load((REPO / "CITATION.cff").read_text())
# From smr_paper.tex (\title, \author) and arXiv 2503.06840; the venue as the issue gives it.
TITLE = "Improving Visual Place Recognition with Sequence-Matching Receptiveness Prediction"
AUTHORS = [("Somayeh", "Hussaini"), ("Tobias", "Fischer"), ("Michael", "Milford")]


def metadata_version() -> str:
    return tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]


def test_citation_file_is_valid_cff_1_2_0():
    schema = json.loads((REPO / "tests" / "data" / "citation" / "cff-1.2.0.schema.json").read_text())
    errors = [error.message for error in jsonschema.Draft7Validator(schema).iter_errors(CITATION)]
    assert errors == []
    assert CITATION["cff-version"] == "1.2.0" and CITATION["type"] == "software"


def test_citation_references_the_smr_paper():
    (paper,) = CITATION["references"]
    assert paper["title"] == TITLE
    assert [(a["given-names"], a["family-names"]) for a in paper["authors"]] == AUTHORS
    assert paper["year"] == 2025 and "IROS" in paper["collection-title"]
    assert paper["url"] == "https://arxiv.org/abs/2503.06840"
    # The report's line names the same paper.
    assert TITLE in PAPER and "2025" in PAPER and "arXiv:2503.06840" in PAPER
    assert [family for _, family in AUTHORS] == re.findall(r"[A-Z]\. ([A-Z][a-z]+)", PAPER)


def test_one_version_everywhere():
    expected = metadata_version()
    assert version("vpr-smr") == expected  # the installed metadata (the editable install of this checkout)
    assert CITATION["version"] == expected
    changelog = (REPO / "CHANGELOG.md").read_text()
    assert re.findall(r"^## (\S+) - (\d{4}-\d{2}-\d{2})$", changelog, re.M)[0] == (expected,
                                                                                     CITATION["date-released"])
    printed = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "--version"], capture_output=True,
                             text=True, check=True).stdout
    assert printed == f"vpr-smr {expected}\n"
    assert f"version {expected} (CITATION.cff)" in how_to_cite(expected)
    readme = (REPO / "README.md").read_text()
    assert f'for visual place recognition", version {expected}.' in readme.split("## How to cite")[1]


def test_every_licence_file_named_in_the_metadata_exists():
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    for pattern in project["license-files"]:
        assert list(REPO.glob(pattern)), pattern
    # Every licence file under data/ is named, so that none is left out of the wheel's metadata.
    shipped = {p.relative_to(REPO) for p in (REPO / "data").rglob("*") if "LICENSE" in p.name.upper()}
    named = {p.relative_to(REPO) for pattern in project["license-files"] for p in REPO.glob(pattern)}
    assert shipped and shipped <= named
