"""The README is a short user's page; it and the docs stand alone (no path outside the repository) and name
commands that exist."""

import argparse
import re

import pytest

from robocompose.cli import parser
from robocompose.io.provenance import ROOT

README_MAX_LINES = 250

# An absolute path of a machine, or a path that climbs out of the repository.
OUTSIDE = re.compile(r"(?<![\w.:/])(/(?:work|home|root|tmp|mnt|Users|usr|opt|var)/[\w./-]+|\.\./[\w./-]+)")
DOCUMENTS = ["README.md", "CHANGELOG.md", "reports/report.md", "reports/report.html",
             *sorted(str(path.relative_to(ROOT)) for path in (ROOT / "docs").glob("*.md"))]


def readme() -> str:
    return (ROOT / "README.md").read_text()


@pytest.mark.parametrize("name", DOCUMENTS)
def test_names_no_path_outside_the_repository(name):
    text = (ROOT / name).read_text()
    assert OUTSIDE.findall(text) == []


def test_the_pattern_sees_outside_paths():
    assert OUTSIDE.findall("see `../shared/reference/thesis.md` or /work/main/data, not data/x or a/../b") == [
        "../shared/reference/thesis.md", "/work/main/data"]


def test_the_readme_is_short():
    assert len(readme().splitlines()) <= README_MAX_LINES


def test_the_thesis_is_cited_by_title_and_author():
    assert 'Composition Learning in "Modular" Robot Systems' in readme() and "Jiaheng Hu" in readme()


def subcommands(command: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    actions = [a for a in command._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(actions[0].choices) if actions else {}


def named_commands(text: str) -> list[tuple[str, list[str]]]:
    """Each `robocompose COMMAND [SUB | {SUB,...}]` the text names, with the sub-commands it names."""
    found = []
    for command, sub in re.findall(r"robocompose ([a-z][\w-]*)(?: (\{[\w,-]+\}|[a-z][\w-]*))?", text):
        found.append((command, sub.strip("{}").split(",") if sub else []))
    return found


def test_the_command_pattern_sees_sub_commands():
    assert named_commands("`robocompose modular {ga,probe} --x` and robocompose profile NAME") == [
        ("modular", ["ga", "probe"]), ("profile", [])]


@pytest.mark.parametrize("name", [name for name in DOCUMENTS if not name.startswith("reports/")])
def test_every_command_a_page_names_exists(name):
    commands = subcommands(parser())
    named = named_commands((ROOT / name).read_text())
    assert name != "README.md" or len(named) >= 10
    for command, subs in named:
        assert command in commands, f"{name} names `robocompose {command}`, not a command"
        nested = subcommands(commands[command])
        for sub in subs if nested else []:
            assert sub in nested, f"{name} names `robocompose {command} {sub}`, not a sub-command"


def test_every_make_target_the_readme_names_exists():
    makefile = (ROOT / "Makefile").read_text()
    targets = set(re.findall(r"^([\w-]+):", makefile, flags=re.MULTILINE))
    named = set(re.findall(r"\bmake ([a-z][\w-]*)", readme()))
    assert {"run", "test", "bench", "profile"} <= named
    assert named <= targets, sorted(named - targets)


def test_every_page_the_readme_points_to_exists():
    pages = set(re.findall(r"\b((?:docs/[\w-]+|CHANGELOG)\.md)\b", readme()))
    assert "CHANGELOG.md" in pages and len(pages) >= 8
    assert [page for page in sorted(pages) if not (ROOT / page).is_file()] == []
