"""The release files at the top of the repository agree with the package: LICENSE, CHANGELOG.md,
CITATION.cff and `uqdrive --version` name the same licence and version as pyproject.toml."""

import re
import tomllib

import yaml

from uqdrive.cli.main import main

from conftest import REPO

PROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]


def test_version_flag_prints_the_package_version(capsys):
    from uqdrive._version import __version__

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"uqdrive {__version__}"


def test_license_is_the_declared_one():
    assert PROJECT["license"] == "MIT"
    assert (REPO / "LICENSE").read_text().startswith("MIT License")


def test_citation_file_is_cff_1_2_with_the_package_version():
    cff = yaml.safe_load((REPO / "CITATION.cff").read_text())
    # the keys CFF 1.2.0 requires of every citation file
    assert {"cff-version", "message", "title", "authors"} <= set(cff)
    assert cff["cff-version"] == "1.2.0" and str(cff["version"]) == PROJECT["version"] and cff["license"] == "MIT"
    assert all("name" in a or "family-names" in a for a in cff["authors"])


def test_changelog_has_a_section_for_the_package_version():
    text = (REPO / "CHANGELOG.md").read_text()
    assert "keepachangelog.com" in text
    versions = re.findall(r"^## \[([^\]]+)\]", text, re.M)
    assert versions[0] == "Unreleased" and PROJECT["version"] in versions
