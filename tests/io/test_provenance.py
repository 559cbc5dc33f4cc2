from pathlib import Path

import pytest

import robocompose
from robocompose.io.provenance import ROOT, code_digest, import_closure, module_path

PKG = Path(robocompose.__file__).parent


def test_closure_follows_imports_transitively_and_includes_parent_packages():
    files = {p.relative_to(ROOT).as_posix() for p in import_closure("robocompose.sim.builder")}
    # builder imports grammar.tree, which imports grammar.rules; importing them runs the package inits.
    assert {"robocompose/sim/builder.py", "robocompose/grammar/tree.py", "robocompose/grammar/rules.py",
            "robocompose/grammar/__init__.py", "robocompose/__init__.py"} <= files
    assert "robocompose/latent/model.py" not in files
    assert len(code_digest("robocompose.sim.builder")) == 16


def test_closure_of_a_script_and_function_level_and_relative_imports(tmp_path):
    script = tmp_path / "stage.py"
    script.write_text("import os\n\ndef main():\n    from robocompose.io import provenance\n")
    files = {p.name for p in import_closure(script)}
    assert "provenance.py" in files and "stage.py" not in files
    assert module_path("os") is None and module_path("robocompose.nosuch") is None


def test_digest_changes_with_the_source_of_any_module_in_the_closure(package):
    import robocompose.io.provenance as prov

    package({"top.py": "from . import low\n", "low.py": "X = 1\n"})
    before = prov.code_digest("robocompose.a.top")
    assert {p.name for p in prov.import_closure("robocompose.a.top")} == {"__init__.py", "top.py", "low.py"}
    package({"low.py": "X = 2\n"})
    assert prov.code_digest("robocompose.a.top") != before


def test_excluded_modules_leave_the_digest():
    assert code_digest("robocompose.sim.builder", exclude=("robocompose.io",)) != code_digest("robocompose.sim.builder")
    less = ("robocompose.sim", "robocompose.io")  # sim's package imports io (its banner silencer)
    assert code_digest("robocompose.sim.builder", exclude=less) == code_digest(
        "robocompose.grammar.tree", exclude=less)  # builder's closure less sim (and io) is tree's


@pytest.fixture
def package(tmp_path, monkeypatch):
    """A tiny `robocompose` tree under tmp_path that the provenance functions read instead of the real one."""
    import robocompose.io.provenance as prov

    pkg = tmp_path / "robocompose"
    (pkg / "a").mkdir(parents=True)
    for init in (pkg / "__init__.py", pkg / "a" / "__init__.py"):
        init.write_text("")
    monkeypatch.setattr(prov, "ROOT", tmp_path)

    def write(files: dict[str, str]) -> None:
        for name, text in files.items():
            (pkg / "a" / name).write_text(text)
        for cached in (prov.import_closure, prov.definitions, prov._reached, prov.code_digest):
            cached.cache_clear()

    yield write
    for cached in (prov.import_closure, prov.definitions, prov._reached, prov.code_digest):
        cached.cache_clear()


ENTRY = ("from robocompose.a.low import helper\n\ndef entry(x):\n    return helper(x) + 1\n\n"
         "def unused():\n    return 0\n")
LOW = ('import math\n\ndef helper(x):\n    """Doc."""\n    if x < 0:\n        raise ValueError("no")\n'
       '    return math.sqrt(x)\n')


def test_result_digest_survives_moves_imports_docs_and_messages_but_not_code(package):
    import robocompose.io.provenance as prov

    package({"top.py": ENTRY, "low.py": LOW})
    before = prov.result_digest("robocompose.a.top:entry")
    moved = ('from robocompose.errors import InputError\nimport math\n\n\ndef helper(x: float) -> float:  # note\n'
             '    if x < 0:\n        raise InputError(f"negative {x}")\n    return math.sqrt(x)\n')
    package({"top.py": ENTRY.replace("robocompose.a.low", "robocompose.a.mid"), "low.py": "", "mid.py": moved})
    assert prov.result_digest("robocompose.a.top:entry") == before  # moved, new error type, annotations, comment
    package({"top.py": ENTRY.replace("return 0", "return 1"), "low.py": LOW})
    assert prov.result_digest("robocompose.a.top:entry") == before  # code the entry does not reach
    package({"top.py": ENTRY, "low.py": LOW.replace("math.sqrt(x)", "math.sqrt(x) * 2")})
    assert prov.result_digest("robocompose.a.top:entry") != before
    with pytest.raises(ValueError, match="no definition named 'nosuch'"):
        prov.result_digest("robocompose.a.top:nosuch")


def test_code_digest_is_the_same_after_a_move_between_modules(package):
    import robocompose.io.provenance as prov

    package({"top.py": ENTRY, "low.py": LOW})
    before = prov.code_digest("robocompose.a.top")
    package({"top.py": ENTRY.replace("from robocompose.a.low import helper\n", "") + LOW, "low.py": ""})
    assert prov.code_digest("robocompose.a.top") == before
    package({"top.py": ENTRY.replace("return 0", "return 1"), "low.py": LOW})
    assert prov.code_digest("robocompose.a.top") != before


def test_result_digest_reads_reached_constants_at_call_time(monkeypatch):
    import robocompose.sim.builder as builder
    from robocompose.io.provenance import result_digest

    before = result_digest("robocompose.evaluation.evaluate:evaluate")
    monkeypatch.setattr(builder, "KP", builder.KP * 2)  # a motor gain the episode's robot uses
    assert result_digest("robocompose.evaluation.evaluate:evaluate") != before
