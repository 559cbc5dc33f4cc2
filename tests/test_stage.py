"""Stage scripts: bad params or artifacts end a stage with one line `stage NAME: error: ...` and exit code 2."""

import json
import os
import runpy
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from robocompose.io.dispatch import OPT_OUT, PINNED, has_baseline
from robocompose.io.errors import InputError
from robocompose.stage import run_stage

ROOT = Path(__file__).resolve().parents[1]
STAGES = ROOT / "stages"


def test_input_error_is_one_line_and_exit_2(monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["stages/some_stage.py"])

    def main() -> None:
        raise InputError("params.yaml: x.y: expected 1\nfound 2")

    with pytest.raises(SystemExit) as exit_:
        run_stage(main)
    assert exit_.value.code == 2
    assert capsys.readouterr().err == "stage some_stage: error: params.yaml: x.y: expected 1; found 2\n"


def test_ctrl_c_is_one_line_and_exit_130(monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["stages/some_stage.py"])

    def main() -> None:
        raise KeyboardInterrupt

    with pytest.raises(SystemExit) as exit_:
        run_stage(main)
    assert exit_.value.code == 130 and capsys.readouterr().err == "stage some_stage: interrupted\n"


def test_a_bug_keeps_its_traceback():
    def main() -> None:
        raise ZeroDivisionError("a bug, not bad input")

    with pytest.raises(ZeroDivisionError):
        run_stage(main)


def test_every_stage_script_runs_through_run_stage():
    for script in sorted(STAGES.glob("*.py")):
        assert "    run_stage(main)" in script.read_text(), f"{script.name} does not call run_stage(main)"


def _params(change: str) -> dict:
    document = yaml.safe_load((ROOT / "profiles" / "default.yaml").read_text())
    exec(change, {"doc": document})
    return document


@pytest.mark.parametrize(("stage", "change", "fragments"), [
    ("decompose", "doc['teams']['decompose']['test_fraction'] = 1.5",
     ["params.yaml: teams.decompose.test_fraction: expected a share strictly between 0 and 1", "found 1.5"]),
    ("decompose", "del doc['teams']['decompose']", ["params.yaml: teams.decompose: missing section"]),
    ("decompose", "doc['teams']['chips']['n_synthetic'] = -1", ["teams.chips.n_synthetic: expected an integer >= 1"]),
    ("decompose", "doc['teams']['decompose']['n_regions'] = 100000", ["teams.decompose.n_regions: expected an "
                                                                      "integer in 1..64, found 100000"]),
    ("decompose", "doc['teams']['chips']['directory'] = 'nowhere'", ["nowhere: not a directory",
                                                                     "teams.chips.directory"]),
    ("evaluate_references", "doc['evaluate_references']['n_random'] = -3",
     ["params.yaml: evaluate_references.n_random: expected an integer >= 0, found -3"]),
    ("modular_exhaustive", "doc['compute']['workers'] = -1", ["params.yaml: compute.workers: expected an integer"]),
    ("glso", "doc['compute']['address'] = 'localhost:8786'",
     ["params.yaml: compute.address: expected a Dask scheduler address like tcp://host:8786, found 'localhost:8786'"]),
    ("enumerate", "doc['compute']['address'] = 'tcp://127.0.0.1:9'",  # the discard port: nothing listens there
     ["address: no Dask scheduler answered at 'tcp://127.0.0.1:9' within 5 s"]),
    ("modular_exhaustive", "doc['modular']['workers'] = 1", ["params.yaml: modular.workers: unknown field"]),
    ("modular_baselines", "doc['modular']['experiments']['generations'] = 0", ["params.yaml: modular.experiments"]),
])
def test_bad_params_stop_a_stage_before_it_writes(tmp_path, monkeypatch, capsys, stage, change, fragments):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(_params(change)))
    monkeypatch.setattr(sys, "argv", [str(STAGES / f"{stage}.py")])
    with pytest.raises(SystemExit) as exit_:
        runpy.run_path(str(STAGES / f"{stage}.py"), run_name="__main__")
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and err.count("\n") == 1 and err.startswith(f"stage {stage}: error: ")
    assert all(f in err for f in fragments), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["params.yaml"]  # nothing written



STAGE_PRINTING_ITS_DISPATCH = """
import json, os, sys
from robocompose.stage import run_stage

def main():
    print(json.dumps({"argv": sys.argv[1:], "dispatch": {k: os.environ.get(k) for k in PINNED}}))

if __name__ == "__main__":
    run_stage(main)
"""


def test_a_stage_script_runs_under_the_pinned_dispatch_whatever_its_environment(tmp_path):
    if not has_baseline():
        pytest.skip("the pin applies on x86-64-v3 processors only")
    script = tmp_path / "stage_x.py"
    script.write_text(f"PINNED = {sorted(PINNED)!r}\n" + STAGE_PRINTING_ITS_DISPATCH)
    environment = {k: v for k, v in os.environ.items() if k not in PINNED and k != OPT_OUT}
    result = subprocess.run([sys.executable, "-u", str(script), "full"], capture_output=True, text=True, check=True,
                            env={**environment, "ATEN_CPU_CAPABILITY": "default", "OPENBLAS_CORETYPE": "Sandybridge"})
    assert json.loads(result.stdout) == {"argv": ["full"], "dispatch": PINNED}  # re-executed once, same arguments


def test_a_stage_process_prints_its_one_error_line_and_nothing_before_it(tmp_path):
    """A real stage process (re-executed under the pinned dispatch) that imports pybullet before it reads its
    params: stderr is the one error line, pybullet's C banner is not in front of it."""
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(_params("doc['evaluate_references']['n_random'] = -3")))
    done = subprocess.run([sys.executable, str(STAGES / "evaluate_references.py")], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 2 and done.stdout == "", done
    assert done.stderr == ("stage evaluate_references: error: params.yaml: evaluate_references.n_random: expected an "
                           "integer >= 0, found -3\n"), done.stderr
