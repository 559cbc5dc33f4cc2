import json

import pytest

from robocompose.evaluation.manifest import MANIFEST_FILE, claim_directory, read_manifest, record_reproduction
from robocompose.io.errors import InputError


def test_the_manifest_records_the_first_evaluator_adds_tasks_and_refuses_another(tmp_path):
    assert read_manifest(tmp_path) == {}
    claim_directory(tmp_path, {"rung": "s16_h16_e48", "settings_hash": {"flat": "a"}})
    claim_directory(tmp_path, {"rung": "s16_h16_e48", "settings_hash": {"flat": "a", "ridged": "b"}})
    assert json.loads((tmp_path / MANIFEST_FILE).read_text()) == {
        "rung": "s16_h16_e48", "settings_hash": {"flat": "a", "ridged": "b"}}
    with pytest.raises(InputError, match="used rung s16_h16_e48 .* would use s8_h8_e48"):
        claim_directory(tmp_path, {"rung": "s8_h8_e48", "settings_hash": {"flat": "a"}})
    with pytest.raises(InputError, match="campaign.json: the committed runs used rung s16_h16_e48"):
        claim_directory(tmp_path, {"rung": "s16_h16_e48", "settings_hash": {"ridged": "changed"}})
    assert read_manifest(tmp_path)["settings_hash"] == {"flat": "a", "ridged": "b"}  # a refusal writes nothing


def test_a_hash_proven_to_reproduce_the_runs_is_accepted_on_its_task_only(tmp_path):
    claim_directory(tmp_path, {"rung": "s16_h16_e48", "settings_hash": {"flat": "a", "ridged": "b"}})
    with pytest.raises(InputError, match="no committed runs on task 'wall' to reproduce"):
        record_reproduction(tmp_path, "wall", "c", ["d1"])
    record_reproduction(tmp_path, "flat", "c", ["d2", "d1"])
    record_reproduction(tmp_path, "flat", "a", ["d3"])  # the runs' own hash: nothing to record
    claim_directory(tmp_path, {"rung": "s16_h16_e48", "settings_hash": {"flat": "c"}})
    with pytest.raises(InputError, match="the committed runs used rung s16_h16_e48"):
        claim_directory(tmp_path, {"rung": "s16_h16_e48", "settings_hash": {"ridged": "c"}})  # proven on flat only
    assert read_manifest(tmp_path) == {"rung": "s16_h16_e48", "settings_hash": {"flat": "a", "ridged": "b"},
                                       "reproduced": {"flat": {"c": ["d1", "d2"]}}}
