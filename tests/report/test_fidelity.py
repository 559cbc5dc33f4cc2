import json

import numpy as np
import pandas as pd

from robocompose.control.mppi import MPPIConfig
from robocompose.evaluation.fidelity import THESIS, summarise, write_summary
from robocompose.report.fidelity import section


def test_section_shows_every_measured_setting_and_the_choice(tmp_path):
    designs = pd.DataFrame({"name": ["a", "b", "c"], "kind": ["reference", "random", "random"],
                            "design_id": ["ia", "ib", "ic"], "rules": "", "screen_reward": np.nan})
    rows = [(THESIS, [5.0, 4.0, 4.1], 2_229_248), ("s16_h8_e48", [4.6, 4.0, 4.05], 107_264)]
    scores = pd.concat([pd.DataFrame({"task": "flat", "rung": rung, "name": designs["name"],
                                      "design_id": designs["design_id"], "reward": values, "status": "ok",
                                      "objective": values, "sim_steps": steps, "seconds": 1.0})
                        for rung, values, steps in rows], ignore_index=True)
    write_summary(summarise(scores, designs), tmp_path / "fidelity")
    (tmp_path / "metrics").mkdir()
    (tmp_path / "metrics" / "evaluator_fidelity.json").write_text(json.dumps({"rung": "s16_h8_e48", "reason": "r"}))
    text = section(tmp_path, MPPIConfig())
    row = "| flat | s16_h8_e48 | 16/64 | 8 | 48 | 107k | 1.0 | 3 of 3 | 1.00 | yes | 4.00-4.05 | 0 of 0 | - | - |"
    assert row in text
    assert "| flat | thesis | 64/512 | 16 | 128 | 2229k |" in text
    assert "Selected: **s16_h8_e48**" in text and "smoke run" not in text
    (tmp_path / "metrics" / "evaluator_fidelity.json").write_text(json.dumps(
        {"rung": "s16_h8_e48", "rule": "provisional", "reason": "provisional: r"}))
    text = section(tmp_path, MPPIConfig())
    assert "Selected (provisional): **s16_h8_e48**" in text and "is a smoke run" in text


def test_section_says_what_is_missing(tmp_path):
    assert "Not run yet" in section(tmp_path, MPPIConfig())
