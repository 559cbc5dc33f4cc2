import json
import runpy
from pathlib import Path

from robocompose.modular.gate import gate
from robocompose.report.gate import section
from robocompose.report.verdicts import find
from tests.modular.test_gate import _world


def _write(reports: Path, worlds: dict, in_progress: dict | None = None) -> None:
    (reports / "metrics").mkdir(parents=True, exist_ok=True)
    metrics = {"worlds": worlds, "in_progress": in_progress or {}}
    (reports / "metrics" / "modular_gate.json").write_text(json.dumps(metrics, sort_keys=True))


def test_the_gate_section_names_the_passing_world_and_orders_best_of_k(tmp_path: Path) -> None:
    deciding, flat = _world(30, 60, decides=True), _world(30, 60, decides=False)
    _write(tmp_path, {"steps": gate(*deciding).summary, "block world": gate(*flat).summary})
    text = section(tmp_path)
    [stated] = find(text)  # the verdict the report's summary lists
    assert stated.outcome == "holds"
    assert stated.detail == "Passes: steps; of block world (30 terrains), steps (30 terrains)."
    rows = [line for line in text.splitlines() if line.startswith("| block world")]
    assert [row.split(" | ")[3] for row in rows] == ["1", "3", "10"]  # by k, not JSON's string order
    assert all(row.endswith("| no |") for row in rows)


def test_the_gate_section_says_when_no_world_passes_and_when_the_stage_has_not_run(tmp_path: Path) -> None:
    assert "Not run yet" in section(tmp_path) and "modular_gate" in section(tmp_path)
    _write(tmp_path, {"block world": gate(*_world(30, 60, decides=False)).summary})
    [stated] = find(section(tmp_path))
    assert stated.outcome == "does NOT hold" and stated.detail.startswith("Of block world (30 terrains): in none")
    _write(tmp_path, {"block world": gate(*_world(30, 60, decides=False)).summary},
           {"mixed": {"terrains": 4, "planned": 20}})
    [stated] = find(section(tmp_path))  # a probe in pieces is named, never gated on its first terrains
    assert stated.detail.endswith("; probes in progress, not gated: mixed (4 of 20 terrains).")
    assert "| mixed" not in section(tmp_path)


def test_the_stage_gates_full_probes_only_and_names_those_in_progress(tmp_path: Path) -> None:
    stage = runpy.run_path(str(Path(__file__).parents[2] / "stages" / "modular_gate.py"))
    for name, count in {"walls": stage["PROBE_TERRAINS"], "mixed": 4, "empty": 0}.items():
        (tmp_path / name).mkdir()
        for seed in range(count):
            (tmp_path / name / f"{name}-{30000 + seed}.parquet").touch()
    gated, in_progress = stage["worlds"](tmp_path)
    assert list(gated) == ["block world", "walls"] and gated["walls"] == [tmp_path / "walls"]
    assert in_progress == {"mixed": 4}
