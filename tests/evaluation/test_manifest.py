import json

import pytest

from robocompose.evaluation.manifest import MANIFEST_FILE, claim_directory, read_manifest
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
