"""Measured truth apart from output (issue 44, item 3): `reports/` holds only what the pipeline writes, and the
committed measurements that stages read (exhaustive tables, fidelity pieces, campaign runs, generator pieces) live
under `measured/`.

- Every tracked file under reports/ is a DVC stage's output (outs, metrics, plots) or a known output of a command
  (`make bench`).
- Every file a stage reads (a dvc.yaml dep other than code) is another stage's output, or a committed measurement
  under measured/; no stage declares an output under measured/.
- Every `reports/...` path the code (robocompose/, stages/, flows/, benchmarks/) or a profile names is an output,
  so nothing reads committed truth from reports/; every `measured/...` path a profile names is committed.
"""

from __future__ import annotations

import ast
import fnmatch
import subprocess
from pathlib import Path

import pytest
import yaml

from robocompose.io.provenance import ROOT

REPORTS, MEASURED = "reports", "measured"
CODE_DEPS = ("robocompose/", "robocompose", "stages/")
CODE_FOLDERS = ("robocompose", "stages", "flows", "benchmarks")
# Outputs under reports/ that no DVC stage declares, and what writes them.
KNOWN_OUTPUTS = {
    "reports/benchmarks.json": "`make bench` (benchmarks/__main__.py); the report stage reads it",
    "reports/timings.json": "every stage's wall times (git-ignored, kept out of DVC so outputs stay byte-identical)",
}


def covered(path: str, paths: list[str]) -> bool:
    """`path` is one of `paths` or inside one of them."""
    return any(path == p or path.startswith(p.rstrip("/") + "/") for p in paths)


def names_output(text: str, outputs: list[str]) -> bool:
    """`text` (a path, or an f-string's glob) is an output, lies inside one, or is a folder holding one."""
    text = text.rstrip("/")
    return any(fnmatch.fnmatchcase(out, text) or covered(text, [out]) or fnmatch.fnmatchcase(out, text + "/*")
               for out in outputs)


def report_problems(tracked: list[str], outputs: list[str]) -> list[str]:
    """Tracked files under reports/ that are no stage's output and no known output."""
    return [f"{path}: tracked under reports/ but no stage writes it (committed truth goes under measured/)"
            for path in tracked if path.startswith(REPORTS + "/")
            and not covered(path, outputs) and path not in KNOWN_OUTPUTS]


def dep_problems(deps: dict[str, list[str]], outputs: list[str], tracked: list[str]) -> list[str]:
    """Stage reads that are neither an output nor a committed measurement under measured/, and outputs declared
    under measured/."""
    problems = []
    for stage, paths in sorted(deps.items()):
        for dep in paths:
            if dep.startswith(CODE_DEPS) or names_output(dep, outputs) or dep in KNOWN_OUTPUTS:
                continue
            if dep.startswith(MEASURED + "/"):
                if not any(covered(f, [dep]) for f in tracked):
                    problems.append(f"stage {stage}: reads {dep}, which is not committed")
                continue
            problems.append(f"stage {stage}: reads {dep}, which no stage writes and which is not under {MEASURED}/")
    problems += [f"{out}: a stage output under {MEASURED}/ (outputs go to data/, models/ or reports/)"
                 for out in outputs if out.startswith(MEASURED + "/")]
    return problems


def path_problems(names: dict[str, set[str]], outputs: list[str], tracked: list[str]) -> list[str]:
    """`reports/...` paths named in code or profiles that are no output; `measured/...` paths a profile names that
    are not committed (code may name a folder a command fills later; a profile's template, `.../vae_{variant}.pt`,
    names files a command writes into a folder that must be committed). `names`: where -> the path strings there."""
    problems = []
    for where, texts in sorted(names.items()):
        for text in sorted(texts):
            if text.startswith(REPORTS + "/") and not (names_output(text, outputs) or text in KNOWN_OUTPUTS):
                problems.append(f"{where}: names {text}, which no stage writes (read committed truth from "
                                f"{MEASURED}/)")
            elif where.endswith(".yaml") and text.startswith(MEASURED + "/") and not any(
                    covered(f, [text.rsplit("/", 1)[0] if "{" in text else text.rstrip("/")]) for f in tracked):
                problems.append(f"{where}: names {text}, which is not committed under {MEASURED}/")
    return problems


def code_paths(path: Path) -> set[str]:
    """The string constants of a file that are paths under reports/ or measured/ (f-strings as globs)."""
    found, parts = set(), set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.JoinedStr):
            found.add("".join(v.value if isinstance(v, ast.Constant) else "*" for v in node.values))
            parts.update(id(v) for v in node.values)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in parts:
            found.add(node.value)
    return {s for s in found if s.startswith((REPORTS + "/", MEASURED + "/")) and not any(c.isspace() for c in s)}


def profile_paths(document: object) -> set[str]:
    if isinstance(document, dict):
        return set().union(set(), *(profile_paths(v) for v in document.values()))
    if isinstance(document, list):
        return set().union(set(), *(profile_paths(v) for v in document))
    return {document} if isinstance(document, str) and document.startswith((REPORTS + "/", MEASURED + "/")) else set()


@pytest.fixture(scope="module")
def project() -> dict:
    from dvc.repo import Repo

    with Repo(str(ROOT)) as repo:
        stages = list(repo.index.stages)
    deps = {stage.addressing: [Path(d.def_path).as_posix().rstrip("/") for d in stage.deps if not hasattr(d, "params")]
            for stage in stages}
    outputs = sorted({Path(out.def_path).as_posix().rstrip("/") for stage in stages for out in stage.outs})
    tracked = subprocess.run(["git", "ls-files", REPORTS, MEASURED], cwd=ROOT, capture_output=True, text=True,
                             check=True).stdout.split()
    names = {str(p.relative_to(ROOT)): code_paths(p) for folder in CODE_FOLDERS for p in (ROOT / folder).rglob("*.py")}
    for path in [ROOT / "params.yaml", *sorted((ROOT / "profiles").glob("*.yaml"))]:
        names[str(path.relative_to(ROOT))] = profile_paths(yaml.safe_load(path.read_text()))
    return {"deps": deps, "outputs": outputs, "tracked": tracked, "names": names}


def test_reports_holds_only_what_the_pipeline_writes(project):
    assert any(f.startswith(REPORTS + "/") for f in project["tracked"])
    problems = report_problems(project["tracked"], project["outputs"])
    assert not problems, "\n".join(problems)


def test_stages_read_committed_measurements_only_from_measured(project):
    assert any(d.startswith(MEASURED + "/") for paths in project["deps"].values() for d in paths)
    problems = dep_problems(project["deps"], project["outputs"], project["tracked"])
    assert not problems, "\n".join(problems)


def test_code_and_profiles_name_outputs_under_reports_and_committed_measurements_under_measured(project):
    assert any(t.startswith(MEASURED + "/") for texts in project["names"].values() for t in texts)
    problems = path_problems(project["names"], project["outputs"], project["tracked"])
    assert not problems, "\n".join(problems)


def test_known_outputs_are_named_by_the_code_that_writes_them(project):
    named = set().union(*project["names"].values())
    assert set(KNOWN_OUTPUTS) <= named


# The rules fail: on the real project with one piece of committed truth put back under reports/.
def test_committed_truth_under_reports_fails(project):
    tracked = [*project["tracked"], "reports/modular/pool/blocks-20000.parquet"]
    assert report_problems(tracked, project["outputs"]) == [
        "reports/modular/pool/blocks-20000.parquet: tracked under reports/ but no stage writes it (committed truth "
        "goes under measured/)"]
    deps = {**project["deps"], "modular_pool": [*project["deps"]["modular_pool"], "reports/modular/pool"]}
    assert dep_problems(deps, project["outputs"], tracked) == [
        "stage modular_pool: reads reports/modular/pool, which no stage writes and which is not under measured/"]
    names = {**project["names"], "robocompose/glso/campaign.py": {"reports/glso_campaign"}}
    assert path_problems(names, project["outputs"], project["tracked"]) == [
        "robocompose/glso/campaign.py: names reports/glso_campaign, which no stage writes (read committed truth "
        "from measured/)"]


def test_a_dep_outside_measured_a_missing_measurement_and_an_output_under_measured_fail(project):
    deps = {"a": ["robocompose/io", "data/designs.parquet", "reference/thesis.md", "measured/nowhere"]}
    outputs = [*project["outputs"], "measured/written.parquet"]
    assert dep_problems(deps, outputs, project["tracked"]) == [
        "stage a: reads reference/thesis.md, which no stage writes and which is not under measured/",
        "stage a: reads measured/nowhere, which is not committed",
        "measured/written.parquet: a stage output under measured/ (outputs go to data/, models/ or reports/)"]
    assert path_problems({"profiles/paper.yaml": {"measured/fidelity/scorez"}}, project["outputs"],
                         project["tracked"]) == [
        "profiles/paper.yaml: names measured/fidelity/scorez, which is not committed under measured/"]
    # a template names files a command writes later: its folder must be committed, not the files
    templates = {"measured/vae_thesis/vae_{variant}.pt", "measured/vae_nowhere/vae_{variant}.pt"}
    assert path_problems({"profiles/paper.yaml": templates}, project["outputs"], project["tracked"]) == [
        "profiles/paper.yaml: names measured/vae_nowhere/vae_{variant}.pt, which is not committed under measured/"]
