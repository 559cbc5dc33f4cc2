"""The README and the committed report stand alone: no path outside the repository."""

import re

import pytest

from robocompose.io.provenance import ROOT

# An absolute path of a machine, or a path that climbs out of the repository.
OUTSIDE = re.compile(r"(?<![\w.:/])(/(?:work|home|root|tmp|mnt|Users|usr|opt|var)/[\w./-]+|\.\./[\w./-]+)")


@pytest.mark.parametrize("name", ["README.md", "reports/report.md", "reports/report.html"])
def test_names_no_path_outside_the_repository(name):
    text = (ROOT / name).read_text()
    assert OUTSIDE.findall(text) == []


def test_the_pattern_sees_outside_paths():
    assert OUTSIDE.findall("see `../shared/reference/thesis.md` or /work/main/data, not data/x or a/../b") == [
        "../shared/reference/thesis.md", "/work/main/data"]


def test_the_thesis_is_cited_by_title_and_author():
    readme = (ROOT / "README.md").read_text()
    assert 'Composition Learning in "Modular" Robot Systems' in readme and "Jiaheng Hu" in readme
