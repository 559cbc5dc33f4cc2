"""dvc.yaml cannot drift from the code: each stage lists every project module it imports and every file it reads.

A stage's code deps are derived from its script by `robocompose.dvc_deps` (`make deps`: the exact cover of its
`import_closure`, transitive, function-level imports included); dvc.yaml must be what it writes, or the test
names each stale stage and says to run `make deps`. The files a stage reads are derived from the path strings
of its script and of the modules it imports, matched against the pipeline's artifacts, plus a hand-kept table of
reads that go through params.
"""

from __future__ import annotations

import ast
import difflib
import fnmatch
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

from robocompose import dvc_deps
from robocompose.io import provenance
from robocompose.io.provenance import import_closure

ROOT = provenance.ROOT
PACKAGE = provenance.PACKAGE

# Reads the path strings of the code do not show (paths built from params or from folder names).
KNOWN_READS = {
    "teams_baselines": {"data/regions.parquet", "data/teams/chips"},  # the regions table names the chip PNGs
    "evaluate_references": {"data/designs.parquet"},
    "modular_baselines": {"data/modular/exhaustive.parquet"},
    "train_eggan_modular": {"data/modular/pool.parquet"},  # eggan_modular.fitness.pool
    "modular_pool_size": {"data/modular/pool.parquet"},
    "modular_realtime": {"data/modular/pool.parquet"},
    "vae_designs": {"data/designs.parquet", "data/designs_nogram.parquet"},
    "train_vae": {"data/designs.parquet", "data/designs_nogram.parquet",  # train_vae.variants
                  "data/vae_extra_designs.parquet", "data/vae_extra_nogram.parquet"},
    "vae_landscape": {"models/vae_full.pt", "models/vae_nopred.pt", "data/designs.parquet"},
    "glso": {"models/vae_full.pt", "models/vae_nopred.pt", "models/vae_nogram.pt"},  # glso.models
    "report": {"data/teams/chips", "data/rollouts", "reports/benchmarks.json", "reports/training"},
}
# Files stages read that are deliberately not DVC deps, and why.
NOT_DEPS = {
    "reports/timings.json": "wall times of the last run, kept out of DVC so that outputs stay byte-reproducible",
    "data/cache/eval_cache.parquet": "the evaluation cache only saves time: its keys cover every input "
                                     "(issue 10, item 3)",
}

# Artifacts the code of a stage names but the stage does not read, and why.
NOT_READ = {
    "teams_eggan": {"measured/teams/generators": "it imports robocompose.teams.generators for train_and_query; "
                                                 "the pieces are written by `robocompose teams generator` and read "
                                                 "by teams_heldout"},
    "glso": {path: "runs.py imports robocompose.evaluation.fidelity for the ladder's rungs (glso.rung); the design "
                   "set and the summary are the evaluator_fidelity stage's"
             for path in ("measured/fidelity/designs.csv", "reports/fidelity/summary.csv")}
    | {"measured/references/eval_cache.parquet": "runs.py imports robocompose.evaluation.references for "
                                                 "record_rollout; the committed evaluations are evaluate_references'"},
    "glso_campaign": {"measured/references/eval_cache.parquet": "it imports robocompose.glso.runs (see glso)",
                      "measured/vae_thesis": "campaign.check_thesis_gate reads the thesis-scale VAE's gate before "
                                             "`glso-campaign run` searches it; the stage summarises committed runs",
                      "reports/metrics/vae_landscape.json": "(the same gate)"}
    | {f"reports/training/vae_{name}/metrics.json": "thesis_scale.progress's summary is its own folder's (see "
                                                    "vae_landscape)" for name in ("full", "nopred", "nogram")},
    "vae_landscape": {f"reports/training/vae_{name}/metrics.json": "thesis_scale.progress reads the dvclive summary "
                      "in its own committed folder (measured/vae_thesis/log/VARIANT/metrics.json, a dep)"
                      for name in ("full", "nopred", "nogram")},
    "modular_realtime": {"measured/modular/exhaustive": "it imports robocompose.modular.truth to read the partial "
                                                        "test tables (measured/modular/test_partial, a dep) as "
                                                        "committed tables; the exhaustive ones come through "
                                                        "data/modular/exhaustive.parquet"},
}


def dvc_stages(root: Path = ROOT) -> dict:
    """name -> DVC's own parse of each stage of root/dvc.yaml (a matrix stage expanded: NAME@ITEM)."""
    from dvc.repo import Repo

    with Repo(str(root)) as repo:
        return {stage.addressing: stage for stage in repo.index.stages}


def stage_script(stage) -> str:
    return dvc_deps.stage_script(stage.addressing, stage.cmd)


def dep_paths(stage) -> list[str]:
    return [Path(dep.def_path).as_posix().rstrip("/") for dep in stage.deps if not hasattr(dep, "params")]


def covered(path: str, deps: list[str]) -> bool:
    return any(path == dep or path.startswith(dep + "/") for dep in deps)


def _path_strings(path: Path) -> set[str]:
    """The string constants of a file, f-strings as glob patterns (`f"vae_{name}.pt"` -> `vae_*.pt`)."""
    strings = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.JoinedStr):
            strings.add("".join(v.value if isinstance(v, ast.Constant) else "*" for v in node.values))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            strings.add(node.value)
    return {s for s in strings if "." in Path(s).name and " " not in s and "\n" not in s and not s.startswith("*")}


def artifacts(stages: dict, root: Path = ROOT) -> set[str]:
    """Every file the pipeline passes between stages: DVC outs, tracked reports that no stage writes, and the
    committed measurements under measured/."""
    outs = {Path(out.def_path).as_posix() for stage in stages.values() for out in stage.outs}
    tracked = subprocess.run(["git", "ls-files", "reports", "measured"], cwd=root, capture_output=True,
                             text=True).stdout.split()
    return outs | {f for f in tracked if not covered(f, sorted(outs))} | set(NOT_DEPS)


def named_reads(script: str, stages: dict, root: Path = ROOT) -> list[tuple[str, set[str]]]:
    """(path string, artifacts it names) for each path string in the script and the modules it imports."""
    sources = [root / script, *import_closure(root / script)]
    strings = set().union(*(_path_strings(p) for p in sources))
    found = []
    for text in sorted(strings):
        names = {a for a in artifacts(stages, root)
                 if fnmatch.fnmatchcase(a, text) or fnmatch.fnmatchcase(a, "*/" + text)}
        if names:
            found.append((text, names))
    return found


def read_problems(name: str, script: str, deps: list[str], outs: list[str], stages: dict,
                  root: Path = ROOT) -> list[str]:
    """Files a stage reads that it does not list: known reads, and artifacts its code names."""
    problems = [f"stage {name}: reads {path} but dvc.yaml does not list it"
                for path in sorted(KNOWN_READS.get(name, ())) if not covered(path, deps)]
    for text, names in named_reads(script, stages, root):
        if any(covered(a, deps + outs + sorted(NOT_READ.get(name, ()))) or a in NOT_DEPS for a in names):
            continue  # a pattern (f-string) is satisfied by any one of the artifacts it matches
        problems.append(f"stage {name}: its code names {text!r} ({', '.join(sorted(names))}) but dvc.yaml "
                        f"lists none of them")
    return problems


def out_paths(stage) -> list[str]:
    return [Path(out.def_path).as_posix() for out in stage.outs]


STAGES = dvc_stages()


def test_the_known_reads_name_real_stages_and_artifacts():
    assert set(KNOWN_READS) <= set(STAGES)
    everything = artifacts(STAGES)
    for name, paths in KNOWN_READS.items():
        assert all(any(covered(a, [p]) for a in everything) for p in paths), (name, paths)
    assert set(NOT_READ) <= set(STAGES)
    for name, paths in NOT_READ.items():
        assert all(any(covered(a, [p]) for a in everything) for p in paths), (name, paths)


def test_dvc_yaml_code_deps_are_what_make_deps_writes():
    text = (ROOT / "dvc.yaml").read_text()
    stale = dvc_deps.stale_stages(text)
    assert not stale, "\n".join([*stale, "run `make deps`"])
    assert dvc_deps.rewrite(text) == text


@pytest.mark.parametrize("name", sorted(STAGES))
def test_stage_can_come_from_the_run_cache_and_takes_no_backend_setting_as_a_param(name):
    """A persisted out turns DVC's run cache off for its stage: checkpoints are no outs. Results do not depend
    on the backend, so pointing `compute:` at a Dask cluster (or another worker count) reruns nothing."""
    stage = STAGES[name]
    assert [str(out) for out in stage.outs if out.persist] == []
    params = {key for dep in stage.deps if hasattr(dep, "params") for key in dep.params}
    assert params & {"compute", "compute.workers", "compute.address"} == set()


@pytest.mark.parametrize("name", sorted(STAGES))
def test_stage_lists_every_file_it_reads(name):
    stage = STAGES[name]
    problems = read_problems(name, stage_script(stage), dep_paths(stage), out_paths(stage), STAGES)
    assert not problems, "\n".join(problems)


@pytest.fixture
def project_copy(tmp_path, monkeypatch):
    """A copy of the package's source that `import_closure` reads instead of the real one."""
    shutil.copytree(ROOT / PACKAGE, tmp_path / PACKAGE, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "stages", tmp_path / "stages", ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(provenance, "ROOT", tmp_path)
    import_closure.cache_clear()
    yield tmp_path
    import_closure.cache_clear()


def test_an_import_added_to_library_code_makes_the_stage_stale_and_make_deps_adds_it(project_copy):
    text = (ROOT / "dvc.yaml").read_text()
    model = project_copy / "robocompose" / "latent" / "model.py"
    model.write_text(model.read_text() + "\n\ndef _uses_gait():\n    from robocompose.modular import controller\n")
    import_closure.cache_clear()
    stale = dvc_deps.stale_stages(text)
    train_vae = [line for line in stale if line.startswith("stage train_vae: add [")]
    assert len(train_vae) == 1 and "'robocompose/modular/controller.py'" in train_vae[0], stale
    rewritten = dvc_deps.rewrite(text)
    assert dvc_deps.stale_stages(rewritten) == []
    assert "robocompose/modular/controller.py" in yaml.safe_load(rewritten)["stages"]["train_vae"]["deps"]
    changed = [line for line in difflib.unified_diff(text.splitlines(), rewritten.splitlines(), n=0, lineterm="")
               if line[:1] in "+-" and line[:3] not in ("+++", "---")]
    assert changed and all(line[1:].startswith("      - robocompose/") for line in changed), changed


TINY_DVC_YAML = """\
stages:
  report:  # a comment that stays
    cmd: python stages/report.py
    deps:
      - robocompose
      - data/table.parquet
    params:
      - gallery
    outs:
      - reports/report.md

# a comment at the end
plots:
  - curve:
      x: step
"""


def test_make_deps_drops_a_dep_the_stage_does_not_import_and_keeps_data_deps_and_comments():
    stale = dvc_deps.stale_stages(TINY_DVC_YAML)
    assert len(stale) == 1 and stale[0].startswith("stage report: add ['stages/report.py', 'robocompose/__init__.py'")
    assert stale[0].endswith("drop ['robocompose']")
    rewritten = dvc_deps.rewrite(TINY_DVC_YAML)
    deps = yaml.safe_load(rewritten)["stages"]["report"]["deps"]
    assert deps == [*(d for d in dep_paths(STAGES["report"]) if d.startswith(("stages/", PACKAGE))),
                    "data/table.parquet"]
    assert "  report:  # a comment that stays\n" in rewritten and "# a comment at the end\nplots:\n" in rewritten
    assert rewritten.count("\n") == TINY_DVC_YAML.count("\n") - 2 + len(deps)


def test_deps_that_are_not_a_block_list_are_refused():
    flow = TINY_DVC_YAML.replace("    deps:\n      - robocompose\n      - data/table.parquet\n",
                                 "    deps: [robocompose, data/table.parquet]\n")
    with pytest.raises(ValueError, match="make deps"):
        dvc_deps.rewrite(flow)


def test_the_command_checks_and_rewrites_the_projects_dvc_yaml(project_copy, capsys):
    good = (ROOT / "dvc.yaml").read_text()
    (project_copy / "dvc.yaml").write_text(good.replace("      - robocompose/sim/render.py\n", ""))
    assert dvc_deps.main(["--check"]) == 1
    out = capsys.readouterr().out.splitlines()
    assert "stage enumerate: add ['robocompose/sim/render.py'], drop []" in out and out[-1] == "run `make deps`"
    assert dvc_deps.main([]) == 0
    assert (project_copy / "dvc.yaml").read_text() == good
    assert dvc_deps.main(["--check"]) == 0


def test_a_read_without_a_dep_fails():
    stage = STAGES["report"]
    deps = [d for d in dep_paths(stage) if d != "reports/benchmarks.json"]
    problems = read_problems("report", stage_script(stage), deps, out_paths(stage), STAGES)
    assert "stage report: reads reports/benchmarks.json but dvc.yaml does not list it" in problems
    assert any(p.startswith("stage report: its code names 'benchmarks.json' (reports/benchmarks.json)")
               for p in problems)


def test_touching_an_imported_module_or_the_benchmarks_makes_dvc_status_list_the_stage(tmp_path, monkeypatch):
    """Through DVC itself, on a copy of the project: record every stage's deps, touch every project module
    and reports/benchmarks.json, then each stage reports as changed a dep covering each module it imports."""
    from dvc.repo import Repo

    for part in (PACKAGE, "stages"):
        shutil.copytree(ROOT / part, tmp_path / part, ignore=shutil.ignore_patterns("__pycache__"))
    for part in ("dvc.yaml", "params.yaml", "reports/benchmarks.json"):
        (tmp_path / part).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / part, tmp_path / part)
    monkeypatch.chdir(tmp_path)  # status names stages relative to the working directory
    Repo.init(str(tmp_path), no_scm=True).close()
    with Repo(str(tmp_path)) as repo, repo.lock:
        for stage in repo.index.stages:
            stage.save(allow_missing=True, run_cache=False)  # as after a run (outputs absent here)
            stage.dump(update_pipeline=False)  # dvc.lock only

    def changed_code() -> dict[str, list[str]]:
        with Repo(str(tmp_path)) as repo:
            status = repo.status()
        return {name: sorted(Path(path).as_posix() for entry in entries if isinstance(entry, dict)
                             for path, state in entry.get("changed deps", {}).items() if state == "modified")
                for name, entries in status.items()}

    assert not any(changed_code().values())  # recorded: only the absent data shows
    for path in (tmp_path / PACKAGE).rglob("*.py"):
        path.write_text(path.read_text() + "\n# touched\n")
    bench = tmp_path / "reports" / "benchmarks.json"
    bench.write_text(bench.read_text() + "\n")
    changed = changed_code()
    for name, stage in STAGES.items():
        for module in import_closure(ROOT / stage_script(stage)):
            path = module.relative_to(ROOT).as_posix()
            assert covered(path, changed.get(name, [])), f"dvc status does not list {name} after touching {path}"
    assert "reports/benchmarks.json" in changed["report"]
