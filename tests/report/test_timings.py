import json

import pytest

from robocompose.report.timings import read_timings, timed


def test_timed_records_each_stage_and_keeps_others(tmp_path):
    path = tmp_path / "timings.json"
    path.write_text(json.dumps({"other": {"seconds": 3.0}}))
    with timed("stage", path) as timing:
        timing["rate"] = 2.5
    recorded = read_timings(path)
    assert recorded["other"] == {"seconds": 3.0}
    assert recorded["stage"]["rate"] == 2.5 and recorded["stage"]["seconds"] >= 0


def test_a_failed_stage_records_nothing(tmp_path):
    path = tmp_path / "timings.json"
    with pytest.raises(RuntimeError), timed("stage", path):
        raise RuntimeError("boom")
    assert not path.exists()
