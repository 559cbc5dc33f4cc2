from pathlib import Path

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


def test_digest_changes_with_the_source_of_any_module_in_the_closure(tmp_path, monkeypatch):
    import robocompose.io.provenance as prov

    pkg = tmp_path / "robocompose"
    (pkg / "a").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a" / "__init__.py").write_text("")
    (pkg / "a" / "top.py").write_text("from . import low\n")
    (pkg / "a" / "low.py").write_text("X = 1\n")
    monkeypatch.setattr(prov, "ROOT", tmp_path)
    before = prov.code_digest.__wrapped__("robocompose.a.top")
    assert {p.name for p in prov.import_closure.__wrapped__("robocompose.a.top")} == {"__init__.py", "top.py",
                                                                                      "low.py"}
    (pkg / "a" / "low.py").write_text("X = 2\n")
    assert prov.code_digest.__wrapped__("robocompose.a.top") != before


def test_excluded_modules_leave_the_digest():
    from robocompose.io.provenance import import_closure

    full = {p.name for p in import_closure("robocompose.fanout.cache")}
    assert {"cache.py", "tables.py", "schemas.py"} <= full
    # the cache module's own closure is storage only: excluding it and io leaves just the package inits
    assert code_digest("robocompose.fanout.cache", exclude=("robocompose.io", "robocompose.fanout.cache")) \
        == code_digest("robocompose.fanout")
    assert code_digest("robocompose.sim.builder", exclude=("robocompose.io",)) != code_digest("robocompose.sim.builder")
