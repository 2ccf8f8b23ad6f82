"""A wheel built from the repository runs the workflow with no checkout: Snakefile, rules, schema, profiles and
the shipped data are package data, and the results equal those of the checkout's install. It holds every module of
the checkout (the package's own, vpr_smr/, and the stage folders'), as files, never links."""

import csv
import email
import stat
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest
import yaml
from helpers import REPO

pytestmark = pytest.mark.slow

CONFIG = {
    "run": "tiny",
    "seq_lens": [3],
    "seeds": 1,
    "modes": ["paper"],
    "trust_levels": [0.0],
    # no root: the loader's default, the sample inside the installed package
    "datasets": {"sample": {"loader": "nordland_sample", "frames": [2000, 2080],
                            "splits": {"train": [0, 40], "val": [40, 60], "test": [60, 80]}}},
    "methods": {"sad": {"backend": "sad"}},
    "predictor": {"max_iter": 40},
    "experiments": {"matchers": False},  # test_plugin_matcher_workflow.py runs it
}


def run(command, cwd, **kwargs):
    result = subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=600, **kwargs)
    assert result.returncode == 0, f"{command}\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    return result


def rows(folder):
    with open(folder / "results" / "tiny" / "tables" / "table1.csv") as handle:
        return list(csv.DictReader(handle))


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheel")
    run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation", "-w", str(out),
         str(REPO)], cwd=out)
    (path,) = out.glob("vpr_smr-*.whl")
    return path


def test_wheel_metadata_names_licences_classifiers_and_urls(wheel):
    with zipfile.ZipFile(wheel) as archive:
        (metadata,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
        message = email.message_from_bytes(archive.read(metadata))
        names = archive.namelist()
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert message["Version"] == project["version"]
    assert message["License-Expression"] == "MIT AND CC-BY-3.0"
    licence_files = message.get_all("License-File")
    assert {"LICENSE", "data/nordland_sample/NORDLAND_LICENSE_NOTE_from_VPR-Bench.txt",
            "data/lists/from_Patch-NetVLAD/LICENSE", "data/lists/from_VPRSNN/LICENSE",
            "data/lists/from_VPRTempo/LICENSE"} <= set(licence_files)
    dist_info = metadata.rsplit("/", 1)[0]
    assert all(f"{dist_info}/licenses/{name}" in names for name in licence_files)  # the files themselves
    assert "Intended Audience :: Science/Research" in message.get_all("Classifier")
    assert "Typing :: Typed" in message.get_all("Classifier")
    assert "vpr_smr/core/py.typed" in names
    # report.html's template, style sheet and sorting script (package data), and the template engine
    assert {f"vpr_smr/eval/report/templates/report.{kind}" for kind in ("html.j2", "css", "js")} <= set(names)
    assert "jinja2>=3.1" in message.get_all("Requires-Dist")
    assert "Paper, https://arxiv.org/abs/2503.06840" in message.get_all("Project-URL")


def test_wheel_holds_every_module_of_the_checkout_as_files(wheel):
    listed = run(["git", "ls-files", "*.py", "*py.typed"], cwd=REPO).stdout.split()
    stages = ("core/", "datasets/", "descriptors/", "eval/", "pipeline/")
    expected = {path if path.startswith("vpr_smr/") else f"vpr_smr/{path}" for path in listed
                if path.startswith(("vpr_smr/", *stages))}
    with zipfile.ZipFile(wheel) as archive:
        entries = archive.infolist()
    names = {entry.filename for entry in entries}
    assert {"vpr_smr/__init__.py", "vpr_smr/api.py", "vpr_smr/records.py", "vpr_smr/pipeline/stages/__init__.py",
            "vpr_smr/core/paths.py"} <= expected
    assert expected - names == set(), "a package missing from pyproject's [tool.setuptools] packages"
    links = [entry.filename for entry in entries if stat.S_ISLNK(entry.external_attr >> 16)]
    assert links == [] and len(names) == len(entries)


def test_installed_wheel_runs_a_configuration_outside_the_repository(wheel, tmp_path):
    venv = tmp_path / "venv"
    run([sys.executable, "-m", "venv", str(venv)], cwd=tmp_path)
    site = run([str(venv / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
               cwd=tmp_path).stdout.strip()
    # The dependencies come from the test's own environment (a path line in a .pth file does not run the
    # editable-install hook that lives there, so vpr_smr itself can only come from the wheel).
    Path(site, "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    run([str(venv / "bin" / "python"), "-m", "pip", "install", "--quiet", "--no-deps", "--no-index", str(wheel)],
        cwd=tmp_path)
    located = run([str(venv / "bin" / "python"), "-c", "import vpr_smr.pipeline as p; print(p.__file__)"],
                  cwd=tmp_path).stdout
    assert located.startswith(site) and str(REPO) not in located
    with zipfile.ZipFile(wheel) as archive:
        (metadata,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
        wheel_version = email.message_from_bytes(archive.read(metadata))["Version"]
    printed = run([str(venv / "bin" / "vpr-smr"), "--version"], cwd=tmp_path).stdout
    assert printed == f"vpr-smr {wheel_version}\n"
    printed = run([str(venv / "bin" / "python"), "-c", "import vpr_smr; print(vpr_smr.__version__, "
                   "vpr_smr.api.__file__.startswith(vpr_smr.__path__[0]), len(vpr_smr.records.__all__) > 20)"],
                  cwd=tmp_path).stdout
    assert printed == f"{wheel_version} True True\n"

    user = tmp_path / "user"
    user.mkdir()
    (user / "my.yaml").write_text(yaml.safe_dump(CONFIG))
    result = run([str(venv / "bin" / "vpr-smr"), "run", "my.yaml"], cwd=user,
                 env={"PATH": "/usr/bin:/bin", "HOME": str(tmp_path)})
    assert f"tables:  {Path('results') / 'tiny' / 'tables'}" in result.stdout

    checkout = tmp_path / "checkout"
    checkout.mkdir()
    (checkout / "my.yaml").write_text(yaml.safe_dump(CONFIG))
    run([sys.executable, "-m", "vpr_smr.pipeline", "run", "my.yaml"], cwd=checkout)
    assert rows(user) == rows(checkout) and len(rows(user)) == 1
