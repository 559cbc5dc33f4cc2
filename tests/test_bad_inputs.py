"""The bad-input corpus: every bad flag, params field and file a user can hand in, each one line on stderr, exit 2,
before any work, nothing written or clobbered. One parametrised test runs them all.

A case runs in a fresh folder holding `params.yaml` (the default profile with the case's `change` applied, a Python
statement on `doc`) and whatever its `setup(folder)` makes; then either `robocompose ARGV` in this process or a DVC
stage's script. It must exit with `code`, print nothing on stdout and one line on stderr (`robocompose: error: ...`
or `stage NAME: error: ...`) holding every fragment, and leave every file of the folder as it was: no output
written, none clobbered. `{tmp}` in argv and fragments is the folder. Slow cases (seconds) are marked and run in
`make test-slow`.

Cases are grouped by what they guard; each group is a list below, and CASES joins them.
"""

from __future__ import annotations

import runpy
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml

from robocompose.io.provenance import ROOT

STAGES = ROOT / "stages"


@dataclass(frozen=True)
class Case:
    id: str
    fragments: tuple[str, ...]  # each must appear in the error line ({tmp}: the case's folder)
    argv: tuple[str, ...] = ()  # `robocompose ARGV`, or
    stage: str = ""  # a stage script of stages/
    change: str = ""  # a statement applied to the default profile's document `doc` before params.yaml is written
    setup: Callable[[Path], None] | None = None  # makes the case's files in its folder
    code: int = 2
    slow: bool = False
    marks: tuple = field(default=())


def png(path: Path, width: int, height: int, colour: tuple[int, int, int] = (255, 255, 255)) -> None:
    from PIL import Image

    Image.new("RGB", (width, height), colour).save(path, format="PNG")


# --- files a command reads, where it writes, and the error line itself (one line, no usage block, no banner) ---
OUTPUTS_AND_LINES = [
    Case("compose teams: a 15000 x 15000 label PNG", ("chip.png: more than 144,000,000 pixels",),
         argv=("compose", "teams", "--chip", "{tmp}/chip.png"), setup=lambda tmp: png(tmp / "chip.png", 15000, 15000)),
    Case("compose modular: a pickled height map", ("--heightmap {tmp}/map.npy: not a .npy array file",),
         argv=("compose", "modular", "--heightmap", "{tmp}/map.npy"),
         setup=lambda tmp: (tmp / "map.npy").write_bytes(b"\x80\x04\x95\x00")),
]

# --- params fields and params files ---
PARAMS = [
    Case("decompose: test_fraction out of range", ("teams.decompose.test_fraction: expected a share",),
         stage="decompose", change="doc['teams']['decompose']['test_fraction'] = 1.5"),
    # a value that would give a wrong answer, or a made-up score, is an error (issue 43)
    Case("glso_campaign: alpha above 1", ("params.yaml: glso_campaign.alpha: expected a finite number in (0, 1), "
                                          "found 1.5",), stage="glso_campaign",
         change="doc['glso_campaign']['alpha'] = 1.5"),
    Case("glso_campaign: negative seeds drop a method", ("params.yaml: glso_campaign.seeds.glso: expected an integer "
                                                         ">= 0", "found -2"),
         stage="glso_campaign", change="doc['glso_campaign']['seeds']['glso'] = -2"),
    Case("glso_campaign: no tasks", ("params.yaml: glso_campaign.tasks: expected at least one task", "found []"),
         stage="glso_campaign", change="doc['glso_campaign']['tasks'] = []"),
    Case("glso_campaign: unknown task", ("params.yaml: glso_campaign.tasks: expected tasks of ['flat'",
                                         "found ['moon']"),
         stage="glso_campaign", change="doc['glso_campaign']['tasks'] = ['moon']"),
    Case("glso_campaign: bootstrap zero", ("params.yaml: glso_campaign.bootstrap: expected an integer >= 1", "found 0"),
         stage="glso_campaign", change="doc['glso_campaign']['bootstrap'] = 0"),
    Case("glso_campaign: bootstrap negative", ("glso_campaign.bootstrap: expected an integer >= 1", "found -1"),
         stage="glso_campaign", change="doc['glso_campaign']['bootstrap'] = -1"),
    Case("glso_campaign: missing directory", ("nowhere: not a directory (glso_campaign.directory",),
         stage="glso_campaign", change="doc['glso_campaign']['directory'] = 'nowhere'"),
    Case("mppi: temperature NaN", ("params.yaml: evaluation.mppi.temperature: expected a finite number > 0, "
                                   "found nan",),
         stage="evaluate_references", change="doc['evaluation']['mppi']['temperature'] = float('nan')"),
    Case("mppi: temperature inf", ("evaluation.mppi.temperature: expected a finite number > 0, found inf",),
         stage="evaluate_references", change="doc['evaluation']['mppi']['temperature'] = float('inf')"),
    Case("mppi: temperature negative", ("evaluation.mppi.temperature: expected a finite number > 0, found -1",),
         stage="glso", change="doc['evaluation']['mppi']['temperature'] = -1"),
    Case("mppi: warm_start_sigma NaN", ("evaluation.mppi.warm_start_sigma: expected a finite number >= 0, found nan",),
         stage="evaluate_references", change="doc['evaluation']['mppi']['warm_start_sigma'] = float('nan')"),
    Case("mppi: history_sigma -inf", ("evaluation.mppi.history_sigma: expected a finite number >= 0, found -inf",),
         stage="evaluate_references", change="doc['evaluation']['mppi']['history_sigma'] = float('-inf')"),
    Case("report: mppi discount NaN", ("params.yaml: evaluation.mppi.discount: expected a finite number in (0, 1], "
                                       "found nan",),
         stage="report", change="doc['evaluation']['mppi']['discount'] = float('nan')"),
    Case("glso: a float without its own range check is NaN", ("params.yaml: glso.bo.xi: expected finite numbers",
                                                               "found nan"),
         stage="glso", change="doc['glso']['bo']['xi'] = float('nan')"),
    Case("modular: terrain friction inf", ("params.yaml: modular.eval.terrain.friction: expected a finite number > 0",
                                           "found inf"),
         stage="modular_exhaustive", change="doc['modular']['eval']['terrain']['friction'] = float('inf')"),
    Case("evaluation: mppi section deleted", ("params.yaml: evaluation.mppi: missing section",),
         stage="evaluate_references", change="del doc['evaluation']['mppi']"),
    Case("train_vae: train section deleted", ("params.yaml: train_vae.train: missing section",),
         stage="train_vae", change="del doc['train_vae']['train']"),
    Case("glso: a method's section deleted", ("params.yaml: glso.ga: missing section",),
         stage="glso", change="del doc['glso']['ga']"),
    Case("evaluation: seed negative", ("params.yaml: evaluation.seed: expected an integer >= 0", "found -1"),
         stage="evaluate_references", change="doc['evaluation']['seed'] = -1"),
    Case("train_vae: lr_decay NaN", ("params.yaml: train_vae.train.lr_decay: expected a finite number in (0, 1], "
                                     "found nan",),
         stage="train_vae", change="doc['train_vae']['train']['lr_decay'] = float('nan')"),
    Case("train_vae: lr NaN", ("train_vae.train.lr: expected a finite number > 0, found nan",),
         stage="train_vae", change="doc['train_vae']['train']['lr'] = float('nan')"),
    Case("train_vae: lr negative", ("train_vae.train.lr: expected a finite number > 0, found -1",),
         stage="train_vae", change="doc['train_vae']['train']['lr'] = -1"),
    Case("train_vae: beta_max inf", ("train_vae.train.beta_max: expected a finite number >= 0, found inf",),
         stage="train_vae", change="doc['train_vae']['train']['beta_max'] = float('inf')"),
    Case("evaluator_fidelity: ceiling_share above 1", ("params.yaml: evaluator_fidelity.ceiling_share: expected a "
                                                       "finite number in (0, 1], found 5.0",),
         stage="evaluator_fidelity", change="doc['evaluator_fidelity']['ceiling_share'] = 5.0"),
    Case("evaluator_fidelity: search_spearman -1", ("evaluator_fidelity.search_spearman: expected a finite number in "
                                                    "(0, 1], found -1",),
         stage="evaluator_fidelity", change="doc['evaluator_fidelity']['search_spearman'] = -1"),
    Case("evaluator_fidelity: min_spearman NaN", ("evaluator_fidelity.min_spearman: expected a finite number in "
                                                  "(0, 1], found nan",),
         stage="evaluator_fidelity", change="doc['evaluator_fidelity']['min_spearman'] = float('nan')"),
    Case("evaluator_fidelity: no rungs", ("params.yaml: evaluator_fidelity.rungs: expected at least one rung",),
         stage="evaluator_fidelity", change="doc['evaluator_fidelity']['rungs'] = []"),
    Case("compute: cache names a directory", ("params.yaml: compute.cache: expected a parquet file or a path not yet "
                                              "taken", "found 'cachedir', a directory"),
         stage="enumerate", change="doc['compute']['cache'] = 'cachedir'",
         setup=lambda tmp: (tmp / "cachedir").mkdir()),
    Case("compute: default cache path is a directory", ("compute.cache:", "eval_cache.parquet', a directory"),
         stage="evaluate_references", setup=lambda tmp: (tmp / "data" / "cache" / "eval_cache.parquet").mkdir(
             parents=True)),
    Case("evaluation: a huge value is cut in the line", ("params.yaml: evaluation.seed: expected int, found [0, 1, 2",
                                                         "more characters)"),
         stage="evaluate_references", change="doc['evaluation']['seed'] = list(range(20000))"),
    # params files themselves
    Case("enumerate: params.yaml missing", ("params.yaml: params file not found",), stage="enumerate",
         setup=lambda tmp: (tmp / "params.yaml").unlink()),
    Case("enumerate: params.yaml a directory", ("params.yaml: params file is a directory",), stage="enumerate",
         setup=lambda tmp: ((tmp / "params.yaml").unlink(), (tmp / "params.yaml").mkdir())),
    Case("enumerate: params.yaml not YAML", ("params.yaml: not valid YAML",), stage="enumerate",
         setup=lambda tmp: (tmp / "params.yaml").write_text("enumerate: {n: [\n")),
    Case("enumerate: params.yaml with an alias", ("params.yaml: YAML anchors and aliases are not allowed",),
         stage="enumerate", setup=lambda tmp: (tmp / "params.yaml").write_text(
             "base: &b {n: 5}\n" + (tmp / "params.yaml").read_text())),
    Case("evaluator-fidelity: a billion laughs as --params", ("{tmp}/laughs.yaml: YAML anchors and aliases are not "
                                                              "allowed", "line 1, column 4"),
         argv=("evaluator-fidelity", "summarise", "--params", "{tmp}/laughs.yaml"),
         setup=lambda tmp: (tmp / "laughs.yaml").write_text(  # 9 levels of 9 aliases: 9^9 strings if expanded
             'a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n'
             + "".join(f"{n}: &{n} [{', '.join([f'*{p}'] * 9)}]\n"
                       for p, n in zip("abcdefgh", "bcdefghi", strict=True)))),
    Case("evaluator-fidelity: --tasks unknown", ("argument --tasks: expected tasks of ['flat'", "found ['moon']"),
         argv=("evaluator-fidelity", "summarise", "--tasks", "moon")),
    Case("glso-campaign: --rung unknown", ("argument --rung: unknown fidelity rung 'fast'",),
         argv=("glso-campaign", "summarise", "--rung", "fast")),
    Case("glso-campaign: alpha NaN in --params", ("{tmp}/p.yaml: glso_campaign.alpha: expected a finite number in "
                                                  "(0, 1), found nan",),
         argv=("glso-campaign", "summarise", "--params", "{tmp}/p.yaml"),
         change="doc['glso_campaign']['alpha'] = float('nan')",
         setup=lambda tmp: (tmp / "p.yaml").write_bytes((tmp / "params.yaml").read_bytes())),
    Case("glso-campaign: missing directory", ("nowhere: not a directory (glso_campaign.directory",),
         argv=("glso-campaign", "summarise"), change="doc['glso_campaign']['directory'] = 'nowhere'"),
    Case("profile: params.yaml is a directory", ("params.yaml: not a file",), argv=("profile", "default"),
         setup=lambda tmp: ((tmp / "profiles").mkdir(), (tmp / "profiles" / "default.yaml").write_bytes(
             (tmp / "params.yaml").read_bytes()), (tmp / "params.yaml").unlink(), (tmp / "params.yaml").mkdir())),
    Case("profile: a NaN temperature in default.yaml", ("default.yaml merged onto default.yaml: evaluation.mppi."
                                                        "temperature: expected a finite number > 0, found nan",),
         argv=("profile", "default"), change="doc['evaluation']['mppi']['temperature'] = float('nan')",
         setup=lambda tmp: ((tmp / "profiles").mkdir(), (tmp / "profiles" / "default.yaml").write_bytes(
             (tmp / "params.yaml").read_bytes()))),
    Case("profile: a profile without the mppi section", ("evaluation.mppi: missing section",),
         argv=("profile", "default"), change="del doc['evaluation']['mppi']",
         setup=lambda tmp: ((tmp / "profiles").mkdir(), (tmp / "profiles" / "default.yaml").write_bytes(
             (tmp / "params.yaml").read_bytes()))),
    Case("profile: an unknown section", ("unknown section 'colour'",), argv=("profile", "default"),
         change="doc['colour'] = {}", setup=lambda tmp: ((tmp / "profiles").mkdir(), (
             tmp / "profiles" / "default.yaml").write_bytes((tmp / "params.yaml").read_bytes()))),
    # ported from tests/test_stage.py and tests/test_params.py (kept there too)
    Case("decompose: section deleted", ("params.yaml: teams.decompose: missing section",), stage="decompose",
         change="del doc['teams']['decompose']"),
    Case("decompose: n_synthetic negative", ("teams.chips.n_synthetic: expected an integer >= 1",), stage="decompose",
         change="doc['teams']['chips']['n_synthetic'] = -1"),
    Case("decompose: n_regions huge", ("teams.decompose.n_regions: expected an integer in 1..64, found 100000",),
         stage="decompose", change="doc['teams']['decompose']['n_regions'] = 100000"),
    Case("decompose: chips directory missing", ("nowhere: not a directory", "teams.chips.directory"),
         stage="decompose", change="doc['teams']['chips']['directory'] = 'nowhere'"),
    Case("evaluate_references: n_random negative", ("params.yaml: evaluate_references.n_random: expected an integer "
                                                    ">= 0, found -3",),
         stage="evaluate_references", change="doc['evaluate_references']['n_random'] = -3"),
    Case("modular_exhaustive: workers negative", ("params.yaml: compute.workers: expected an integer",),
         stage="modular_exhaustive", change="doc['compute']['workers'] = -1"),
    Case("glso: address without a scheme", ("params.yaml: compute.address: expected a Dask scheduler address like "
                                            "tcp://host:8786, found 'localhost:8786'",),
         stage="glso", change="doc['compute']['address'] = 'localhost:8786'"),
    Case("enumerate: no scheduler at the address", ("address: no Dask scheduler answered at 'tcp://127.0.0.1:9' "
                                                    "within 5 s",),
         stage="enumerate", change="doc['compute']['address'] = 'tcp://127.0.0.1:9'", slow=True),
    Case("modular_exhaustive: unknown field", ("params.yaml: modular.workers: unknown field",),
         stage="modular_exhaustive", change="doc['modular']['workers'] = 1"),
    Case("modular_baselines: generations zero", ("params.yaml: modular.experiments",), stage="modular_baselines",
         change="doc['modular']['experiments']['generations'] = 0"),
    Case("modular_exhaustive: course shorter than the episode", ("modular.eval.terrain.x_range: the course ends",),
         stage="modular_exhaustive", change="doc['modular']['eval']['control_steps'] = 250"),
    Case("enumerate: n negative", ("params.yaml: enumerate: n must be a positive integer, got -3",), stage="enumerate",
         change="doc['enumerate']['n'] = -3"),
    Case("enumerate: n not a number", ("params.yaml: enumerate.n: expected int, found 'many'",), stage="enumerate",
         change="doc['enumerate']['n'] = 'many'"),
    Case("glso: bo.init a word", ("params.yaml: glso.bo.init: expected int, found 'six'",), stage="glso",
         change="doc['glso']['bo']['init'] = 'six'"),
    Case("train_vae: predictor not a bool", ("params.yaml: train_vae.variants.full.predictor: expected bool",),
         stage="train_vae", change="doc['train_vae']['variants']['full']['predictor'] = 'yes'"),
    Case("vae_landscape: evaluated zero", ("params.yaml: train_vae.landscape: need 0 < evaluated",),
         stage="vae_landscape", change="doc['train_vae']['landscape']['evaluated'] = 0"),
    Case("modular_realtime: protocol queries zero", ("params.yaml: eggan_modular.protocol.queries: expected a "
                                                     "positive",),
         stage="modular_realtime", change="doc['eggan_modular']['protocol']['queries'] = 0"),
]

# --- sizes and bounds: counts, lengths, pixels, addresses, committed records ---
BOUNDS = [
    Case("compose modular: k zero", ("argument --k: expected an integer >= 1, found 0",),
         argv=("compose", "modular", "--terrain-seed", "1", "--k", "0")),
]

CASES = OUTPUTS_AND_LINES + PARAMS + BOUNDS


def _params(change: str) -> dict:
    document = yaml.safe_load((ROOT / "profiles" / "default.yaml").read_text())
    if change:
        exec(change, {"doc": document})
    return document


def _files(folder: Path) -> dict[str, bytes | None]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() if p.is_file() else None for p in folder.rglob("*")}


@pytest.mark.parametrize("case", [pytest.param(c, id=c.id, marks=[*c.marks, *([pytest.mark.slow] if c.slow else [])])
                                  for c in CASES])
def test_a_bad_input_is_one_line_exit_2_and_nothing_written(case, tmp_path, monkeypatch, capsys):
    folder = tmp_path / "case"
    folder.mkdir()
    (folder / "params.yaml").write_text(yaml.safe_dump(_params(case.change)))
    if case.setup is not None:
        case.setup(folder)
    before = _files(folder)
    monkeypatch.chdir(folder)
    if case.stage:
        monkeypatch.setattr(sys, "argv", [str(STAGES / f"{case.stage}.py")])
        with pytest.raises(SystemExit) as exit_:
            runpy.run_path(str(STAGES / f"{case.stage}.py"), run_name="__main__")
        code, program = exit_.value.code, f"stage {case.stage}"
    else:
        from robocompose.cli import main

        try:
            code = main([a.replace("{tmp}", str(folder)) for a in case.argv])
        except SystemExit as exit_:  # argparse
            code = exit_.code
        program = "robocompose"
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == case.code and out == "", (code, out, err)
    assert len(lines) == 1 and lines[0].startswith(f"{program}: error: "), err
    assert all(f.replace("{tmp}", str(folder)) in lines[0] for f in case.fragments), lines[0]
    assert _files(folder) == before  # nothing written, nothing clobbered
