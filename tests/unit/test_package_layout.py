"""The checkout is the package: ``vpr_smr/`` holds the package's own modules and one relative symlink per stage
folder, the same folders that pyproject's ``package-dir`` builds the wheel from, so that the tools that follow imports
on the checkout (mypy, import-linter, editors) and the installed package see one tree."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib

from helpers import REPO

PACKAGE = REPO / "vpr_smr"


def test_each_stage_folder_of_the_wheel_is_linked_from_vpr_smr():
    package_dir = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]
    assert package_dir.pop("vpr_smr") == "vpr_smr"  # the package's own modules, from the folder itself
    assert {name.removeprefix("vpr_smr.") for name in package_dir} == set(package_dir.values())  # vpr_smr.X = "X"
    links = {entry.name: os.readlink(entry) for entry in PACKAGE.iterdir() if entry.is_symlink()}
    # relative links (a clone anywhere works), one per folder and no other
    assert links == {folder: f"../{folder}" for folder in package_dir.values()}
    assert all((PACKAGE / folder).resolve() == REPO / folder for folder in links)


def test_the_links_are_committed_as_links():
    listed = subprocess.run(["git", "ls-files", "--stage", "vpr_smr"], cwd=REPO, capture_output=True, text=True,
                            check=True).stdout.splitlines()
    modes = {line.split("\t")[1].removeprefix("vpr_smr/"): line.split()[0] for line in listed}
    assert modes["core"] == "120000" and modes["pipeline"] == "120000"  # git's mode of a symbolic link
    assert modes["__init__.py"] == "100644"


def test_a_stage_module_is_one_module_from_the_checkout_and_the_install():
    # the package found from the checkout's root (a notebook or `python -m` started there) and from elsewhere (the
    # editable install) is the same folder, and a stage's module resolves to the stage folder's file
    code = ("import vpr_smr, vpr_smr.core.paths as p, pathlib; "
            "print(pathlib.Path(vpr_smr.__file__).parent, pathlib.Path(p.__file__).resolve())")
    for cwd in (REPO, REPO.parent):
        printed = subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True, check=True)
        assert printed.stdout.split() == [str(PACKAGE), str(REPO / "core" / "paths.py")], cwd
