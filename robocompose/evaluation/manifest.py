"""The evaluator a directory of committed results used (the GLSO campaign's runs), `<directory>/campaign.json`
{"rung": fidelity rung, "settings_hash": {task: EvaluationConfig.settings_hash}}: results are comparable only if
they all used it, and a reader of the results (the latent landscape) learns their rung here.

The settings hash covers the simulation code's definitions, so a refactor that moves no number still changes
it. `"reproduced": {task: {hash: [design ids]}}` records later code proven to be the same evaluator: it
re-simulated those committed designs to the committed rewards bit for bit (`record_reproduction`); such a hash
is accepted as the runs' own."""

from __future__ import annotations

from pathlib import Path

from robocompose.io.atomic import atomic_write_json, read_json
from robocompose.io.errors import InputError

MANIFEST_FILE = "campaign.json"


def read_manifest(directory: str | Path) -> dict:
    """The evaluator of the committed runs ({} before the first run)."""
    path = Path(directory) / MANIFEST_FILE
    return read_json(path) if path.exists() else {}


def claim_directory(directory: str | Path, evaluator: dict) -> None:
    """Write the manifest, or check that the committed runs used `evaluator`: another rung, or another settings
    hash on a task already recorded (other MPPI settings or simulation code), is an InputError naming both.
    Tasks first run later are added."""
    path = Path(directory) / MANIFEST_FILE
    recorded = read_manifest(directory)
    if recorded:
        known = {t: h for t, h in evaluator["settings_hash"].items() if t in recorded["settings_hash"]}
        reproduced = recorded.get("reproduced", {})
        if recorded["rung"] != evaluator["rung"] or any(
                h != recorded["settings_hash"][t] and h not in reproduced.get(t, {}) for t, h in known.items()):
            raise InputError(f"{path}: the committed runs used rung {recorded['rung']} with settings "
                             f"{recorded['settings_hash']}, this campaign would use {evaluator['rung']} with "
                             f"{evaluator['settings_hash']}; move the runs aside to start a new campaign, or set "
                             f"the rung to {recorded['rung']} (and restore the code) to continue this one")
        evaluator = {**recorded, "settings_hash": {**evaluator["settings_hash"], **recorded["settings_hash"]}}
    if evaluator != recorded:
        atomic_write_json(path, evaluator)


def record_reproduction(directory: str | Path, task: str, settings_hash: str, designs: list[str]) -> None:
    """Record that the evaluator of `settings_hash` re-simulated the committed `designs` of `task` to their
    committed rewards bit for bit (the caller checked): from now on the manifest accepts it as the runs' own."""
    path = Path(directory) / MANIFEST_FILE
    recorded = read_manifest(directory)
    if task not in recorded.get("settings_hash", {}):
        raise InputError(f"{path}: no committed runs on task {task!r} to reproduce")
    if settings_hash == recorded["settings_hash"][task]:
        return
    reproduced = recorded.setdefault("reproduced", {}).setdefault(task, {})
    reproduced[settings_hash] = sorted(set(reproduced.get(settings_hash, [])) | set(designs))
    atomic_write_json(path, recorded)
