import json
import subprocess
import sys

import pytest

from robocompose.cli import main


def test_derive_prints_design(capsys, reference_rules):
    assert main(["derive", "--rules", reference_rules]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["complete"] is True and out["n_links"] >= 11 and len(out["design_id"]) == 16


@pytest.mark.parametrize(("rules", "step"), [("0,7,25", "step 2"), ("0,7,7", "step 2"), ("0,7,1", "incomplete")])
def test_derive_bad_sequence_exits_nonzero_naming_the_step(capsys, rules, step):
    assert main(["derive", "--rules", rules]) == 2
    assert step in capsys.readouterr().err


def test_help_does_not_import_torch_or_pybullet():
    code = ("import sys; from robocompose.cli import parser; parser(); "
            "print('torch' in sys.modules, 'pybullet' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.split() == ["False", "False"]
