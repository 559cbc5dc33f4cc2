import ast
import fnmatch
import json
from pathlib import Path

import pytest

from robocompose.io.provenance import ROOT
from robocompose.io.timings import Timing, read_timings, record, timed


def test_timed_records_each_stage_and_keeps_others(tmp_path):
    path = tmp_path / "timings.json"
    path.write_text(json.dumps({"other": {"seconds": 3.0}}))
    with timed("stage", path) as timing:
        timing["rate"] = 2.5
    recorded = read_timings(path)
    assert recorded["other"] == {"seconds": 3.0}
    assert recorded["stage"]["rate"] == 2.5 and recorded["stage"]["seconds"] >= 0


def test_a_job_of_a_stage_records_its_own_figures_beside_the_stage(tmp_path):
    path = tmp_path / "timings.json"
    job = Timing()  # timed where the job runs (a worker), recorded by the stage's process
    job["steps_per_s"] = 4.0
    with timed("stage", path):
        record("stage@job", job.figures(), path)
    recorded = read_timings(path)
    assert set(recorded) == {"stage", "stage@job"}
    assert recorded["stage@job"]["steps_per_s"] == 4.0 and recorded["stage@job"]["seconds"] >= 0


def test_a_failed_stage_records_nothing(tmp_path):
    path = tmp_path / "timings.json"
    with pytest.raises(RuntimeError), timed("stage", path):
        raise RuntimeError("boom")
    assert not path.exists()


def _timed_names(script: Path) -> set[str]:
    """The stage names a script passes to `timed` (f-strings as glob patterns)."""
    names = set()
    for node in ast.walk(ast.parse(script.read_text())):
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "timed" and node.args:
            arg = node.args[0]
            if isinstance(arg, ast.Constant):
                names.add(arg.value)
            elif isinstance(arg, ast.JoinedStr):
                names.add("".join(v.value if isinstance(v, ast.Constant) else "*" for v in arg.values))
    return names


def test_every_dvc_stage_records_its_wall_time_under_its_name():
    from dvc.repo import Repo

    with Repo(str(ROOT)) as repo:
        stages = {s.addressing: next(w for w in s.cmd.split() if w.endswith(".py")) for s in repo.index.stages}
    for name, script in stages.items():
        patterns = _timed_names(ROOT / script)
        assert any(fnmatch.fnmatchcase(name, p) for p in patterns), f"{script} does not time stage {name}"
