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


# a campaign that plans the thesis-scale arm (issue 42, item 6) at a fixed rung (no fidelity stage needed)
THESIS_ARM = "doc['glso_campaign'].update(rung='s8_h8_e48', seeds={'glso_turbo_thesis': 1})"


# --- files a command reads, where it writes, and the error line itself (one line, no usage block, no banner) ---
OUTPUTS_AND_LINES = [
    Case("compose teams: a 15000 x 15000 label PNG", ("chip.png: more than 144,000,000 pixels",),
         argv=("compose", "teams", "--chip", "{tmp}/chip.png"), setup=lambda tmp: png(tmp / "chip.png", 15000, 15000),
         slow=True),
    Case("compose modular: a pickled height map", ("--heightmap {tmp}/map.npy: not a .npy array file",),
         argv=("compose", "modular", "--heightmap", "{tmp}/map.npy"),
         setup=lambda tmp: (tmp / "map.npy").write_bytes(b"\x80\x04\x95\x00")),
    # argparse's own errors: one line `robocompose: error: ...`, no usage block, for sub-commands too
    Case("an unknown command", ("argument command: invalid choice: 'no-such-command'",), argv=("no-such-command",)),
    Case("no command", ("the following arguments are required: command",), argv=()),
    Case("modular probe: required flags missing", ("the following arguments are required: --candidates, --out",),
         argv=("modular", "probe", "--terrain-seed", "1")),
    Case("render: an unknown flag", ("unrecognized arguments: --colour red",),
         argv=("render", "--rules", "0", "--out", "{tmp}/x.png", "--colour", "red")),
    Case("enumerate: --n not an integer", ("argument --n: expected an integer, found 'many'",),
         argv=("enumerate", "--n", "many", "--out", "{tmp}/d.parquet")),
    Case("modular ga: a variant not among the choices", ("argument --variant: invalid choice: 'ga99'",),
         argv=("modular", "ga", "--variant", "ga99", "--terrain-seed", "1")),
    Case("teams nsga2: a flag's value missing", ("argument --seed: expected one argument",),
         argv=("teams", "nsga2", "--synthetic-seed", "0", "--seed")),
    Case("teams nsga2: an unknown genome", ("argument --genome: expected one of fractions, share_split, found 'x'",),
         argv=("teams", "nsga2", "--synthetic-seed", "0", "--genome", "x")),
    # the error line after pybullet was imported (its banner silenced), and one cut to a readable length
    Case("evaluate: an unknown task (after pybullet is loaded)", ("unknown task 'nowhere'", "known tasks"),
         argv=("evaluate", "--rules", "0,12,7,1,12,3,10,1,3,1,12,12,1,3,10,2,16,8,1,3,12,4,1,3,2,12,18,9,18,8,5,5,1,12,"
               "6,3", "--task", "nowhere")),
    Case("evaluate: a 2000-character task name is cut with an ellipsis", ("unknown task 'tttttttttt", "ttt..."),
         argv=("evaluate", "--rules", "0,12,7,1,12,3,10,1,3,1,12,12,1,3,10,2,16,8,1,3,12,4,1,3,2,12,18,9,18,8,5,5,1,"
               "12,6,3", "--task", "t" * 2000)),
    Case("modular probe: a candidates YAML that does not parse (the parser's lines joined)",
         ("{tmp}/candidates.yaml", "; "),
         argv=("modular", "probe", "--candidates", "{tmp}/candidates.yaml", "--terrain-seed", "1", "--out",
               "{tmp}/probe.csv"),
         setup=lambda tmp: (tmp / "candidates.yaml").write_text("tall: {max_height_range: [0.3, 0.4\nlow: [\n")),
    # where a command writes: proven writable before any work (a parent that is a file, a place no file can be
    # created in, a name longer than the file system allows, a directory in place of a file)
    Case("render: --out under /proc", ("argument --out: /proc/x.png: cannot create files in /proc",),
         argv=("render", "--rules", "0,7", "--out", "/proc/x.png")),
    Case("render: --out under a file", ("argument --out: {tmp}/blocker/x.png: {tmp}/blocker is not a directory",),
         argv=("render", "--rules", "0,7", "--out", "{tmp}/blocker/x.png"),
         setup=lambda tmp: (tmp / "blocker").write_text("a file")),
    Case("render: a 300-character --out name", ("argument --out: {tmp}/aaaaaaaaaa", "a name of 304 bytes, expected "
                                                 "at most 233 (the file system allows 255, less 22 for the temporary"),
         argv=("render", "--rules", "0,7", "--out", "{tmp}/" + "a" * 300 + ".png")),
    Case("render: --out is a directory", ("argument --out: {tmp}/folder: is a directory",),
         argv=("render", "--rules", "0,7", "--out", "{tmp}/folder"), setup=lambda tmp: (tmp / "folder").mkdir()),
    Case("render: --out not a .png", ("argument --out: x.jpg: expected a .png file name (it is written as PNG)",),
         argv=("render", "--rules", "0,7", "--out", "x.jpg")),
    Case("export-urdf: --out under /sys", ("argument --out: /sys/robot.urdf: cannot create files in /sys",),
         argv=("export-urdf", "--rules", "0,7", "--out", "/sys/robot.urdf")),
    Case("export-urdf: a missing folder under a file", ("argument --out: {tmp}/blocker/new/r.urdf:", "not a directory"),
         argv=("export-urdf", "--rules", "0,7", "--out", "{tmp}/blocker/new/r.urdf"),
         setup=lambda tmp: (tmp / "blocker").write_text("a file")),
    Case("export-urdf: --out not a .urdf", ("argument --out: robot.xml: expected a .urdf file name",),
         argv=("export-urdf", "--rules", "0,7", "--out", "robot.xml")),
    Case("enumerate: --out under /proc", ("argument --out: /proc/designs.parquet: cannot create files in /proc",),
         argv=("enumerate", "--n", "100000", "--out", "/proc/designs.parquet")),
    Case("enumerate: a 240-character --out name (no room for the temporary name)",
         ("argument --out: {tmp}/dddddddddd", "a name of 248 bytes, expected at most 233"),
         argv=("enumerate", "--n", "100000", "--out", "{tmp}/" + "d" * 240 + ".parquet")),
    Case("enumerate: --out is a directory", ("argument --out: folder: is a directory, expected a file name ending in "
                                             ".parquet",),
         argv=("enumerate", "--n", "2", "--out", "folder"), setup=lambda tmp: (tmp / "folder").mkdir()),
    Case("enumerate: an existing output is not clobbered by a bad flag", ("argument --seed: expected an integer >= 0",),
         argv=("enumerate", "--n", "2", "--seed", "-1", "--out", "{tmp}/d.parquet"),
         setup=lambda tmp: (tmp / "d.parquet").write_bytes(b"an earlier table")),
    Case("glso: --checkpoint under /proc", ("--checkpoint /proc/run.ckpt: cannot create files in /proc",),
         argv=("glso", "--method", "random", "--budget", "100", "--checkpoint", "/proc/run.ckpt")),
    Case("glso: a 300-character --checkpoint name", ("--checkpoint {tmp}/cccccccccc", "a name of 300 bytes"),
         argv=("glso", "--method", "random", "--budget", "100", "--checkpoint", "{tmp}/" + "c" * 300)),
    Case("glso: --checkpoint under a file", ("--checkpoint {tmp}/blocker/run.ckpt: {tmp}/blocker is a file",),
         argv=("glso", "--method", "random", "--checkpoint", "{tmp}/blocker/run.ckpt"),
         setup=lambda tmp: (tmp / "blocker").write_text("a file")),
    Case("glso: --checkpoint is a directory", ("--checkpoint {tmp}/folder: is a directory",),
         argv=("glso", "--method", "random", "--checkpoint", "{tmp}/folder"),
         setup=lambda tmp: (tmp / "folder").mkdir()),
    Case("glso: the step table --out under /sys", ("--out /sys/steps.parquet: cannot create files in /sys",),
         argv=("glso", "--method", "random", "--budget", "100", "--out", "/sys/steps.parquet")),
    Case("glso: the step table --out not a .parquet", ("--out {tmp}/steps.csv: expected a .parquet file name",),
         argv=("glso", "--method", "random", "--out", "{tmp}/steps.csv")),
    Case("evaluate: --mcap under /proc", ("argument --mcap: /proc/run.mcap: cannot create files in /proc",),
         argv=("evaluate", "--rules", "0,7", "--mcap", "/proc/run.mcap")),
    Case("evaluate: a 300-character --gif name", ("argument --gif: {tmp}/gggggggggg", "a name of 304 bytes"),
         argv=("evaluate", "--rules", "0,7", "--gif", "{tmp}/" + "g" * 300 + ".gif")),
    Case("evaluate: --gif under a file", ("argument --gif: {tmp}/blocker/run.gif: {tmp}/blocker is not a directory",),
         argv=("evaluate", "--rules", "0,7", "--gif", "{tmp}/blocker/run.gif"),
         setup=lambda tmp: (tmp / "blocker").write_text("a file")),
    Case("evaluate: --mcap is a directory", ("argument --mcap: folder: is a directory, expected a file name ending in "
                                             ".mcap",),
         argv=("evaluate", "--rules", "0,7", "--mcap", "folder"), setup=lambda tmp: (tmp / "folder").mkdir()),
    Case("evaluate: --params missing", ("missing.yaml: params file not found",),
         argv=("evaluate", "--rules", "0,12,7,1,12,3,10,1,3,1,12,12,1,3,10,2,16,8,1,3,12,4,1,3,2,12,18,9,18,8,5,5,1,"
               "12,6,3", "--params", "missing.yaml")),
    Case("modular evaluate: --mcap under /sys", ("argument --mcap: /sys/rollout.mcap: cannot create files in /sys",),
         argv=("modular", "evaluate", "--design", "llllll", "--terrain-seed", "1", "--mcap", "/sys/rollout.mcap")),
    Case("modular probe: --out under /proc", ("argument --out: /proc/probe.csv: cannot create files in /proc",),
         argv=("modular", "probe", "--candidates", "{tmp}/candidates.yaml", "--terrain-seed", "1", "--out",
               "/proc/probe.csv"),
         setup=lambda tmp: (tmp / "candidates.yaml").write_text("tall: {max_height_range: [0.3, 0.4]}\n")),
    Case("modular probe: no room for the criterion file's name beside --out",
         ("argument --out: {tmp}/" + "p" * 40 + "...", "a name of 236 bytes, expected at most 233"),
         argv=("modular", "probe", "--candidates", "{tmp}/candidates.yaml", "--terrain-seed", "1", "--out",
               "{tmp}/" + "p" * 222 + ".csv"),
         setup=lambda tmp: (tmp / "candidates.yaml").write_text("tall: {max_height_range: [0.3, 0.4]}\n")),
    Case("modular probe: --candidates missing", ("argument --candidates: {tmp}/none.yaml: no such file, expected "
                                                 "candidates YAML",),
         argv=("modular", "probe", "--candidates", "{tmp}/none.yaml", "--terrain-seed", "1", "--out",
               "{tmp}/probe.csv")),
    Case("modular exhaustive: --out-dir under /proc", ("argument --out-dir: /proc/tables: cannot create files in "
                                                       "/proc",),
         argv=("modular", "exhaustive", "--terrain-seed", "1", "--out-dir", "/proc/tables")),
    Case("modular exhaustive: --out-dir under a file", ("argument --out-dir: {tmp}/blocker/tables: {tmp}/blocker is "
                                                        "a file, expected a directory",),
         argv=("modular", "exhaustive", "--terrain-seed", "1", "--out-dir", "{tmp}/blocker/tables"),
         setup=lambda tmp: (tmp / "blocker").write_text("a file")),
    Case("modular exhaustive: a 300-character --out-dir name",
         ("argument --out-dir: {tmp}/" + "e" * 40 + "...", "a name of 300 bytes, expected at most 255"),
         argv=("modular", "exhaustive", "--terrain-seed", "1", "--out-dir", "{tmp}/" + "e" * 300 + "/tables")),
    # files a command reads
    Case("sample: --model missing", ("argument --model: {tmp}/none.pt: no such file",),
         argv=("sample", "--model", "{tmp}/none.pt", "--n", "1")),
    Case("teams nsga2: --chip not an image",
         ("{tmp}/notes.txt: not a readable image, expected a DroneDeploy label PNG",),
         argv=("teams", "nsga2", "--chip", "{tmp}/notes.txt"), setup=lambda tmp: (tmp / "notes.txt").write_text("hi")),
    Case("compose ship-modular: --from a directory",
         ("argument --from", "{tmp}/folder: a directory, expected an EG-GAN generator file"),
         argv=("compose", "ship-modular", "--from", "{tmp}/folder"), setup=lambda tmp: (tmp / "folder").mkdir()),
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
    Case("glso_campaign: a held-out seed is a re-score seed", (
        "params.yaml: glso_campaign.heldout_seeds: expected controller seeds disjoint from rescore_seeds [101, 102]",
        "found [201, 202, 203, 101]"), stage="glso_campaign",
         change="doc['glso_campaign']['heldout_seeds'] = [201, 202, 203, 101]"),
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
    Case("glso-campaign: a thesis-scale arm before its VAE is trained",
         ("measured/vae_thesis/vae_full.pt: the thesis-scale VAE of method glso_turbo_thesis is missing",),
         argv=("glso-campaign", "run"), change=THESIS_ARM),
    Case("glso-campaign: a thesis-scale arm before its VAE is gated",
         ("reports/metrics/vae_landscape.json: not found; the thesis-scale VAE is gated by stage vae_landscape",),
         argv=("glso-campaign", "run"), change=THESIS_ARM, setup=lambda tmp: (
             (tmp / "measured" / "vae_thesis").mkdir(parents=True),
             (tmp / "measured" / "vae_thesis" / "vae_full.pt").write_bytes(b"not gated"))),
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
    Case("glso: an unknown rung", ("params.yaml: glso.rung: expected \"\" (the evaluator's evaluation.mppi) or a "
                                   "fidelity rung of ['thesis', 's8_h8_e48',", "found 'fast'"), stage="glso",
         change="doc['glso']['rung'] = 'fast'"),
    Case("train_vae: predictor not a bool", ("params.yaml: train_vae.variants.full.predictor: expected bool",),
         stage="train_vae", change="doc['train_vae']['variants']['full']['predictor'] = 'yes'"),
    Case("train_vae: a variant missing", ("params.yaml: train_vae.variants: expected the variants dvc.yaml declares "
                                          "outputs for: full, nopred, nogram, found ['full', 'nogram']",),
         stage="train_vae", change="del doc['train_vae']['variants']['nopred']"),
    Case("vae_landscape: evaluated zero", ("params.yaml: train_vae.landscape: need 0 < evaluated",),
         stage="vae_landscape", change="doc['train_vae']['landscape']['evaluated'] = 0"),
    Case("modular_realtime: protocol queries zero", ("params.yaml: eggan_modular.protocol.queries: expected a "
                                                     "positive",),
         stage="modular_realtime", change="doc['eggan_modular']['protocol']['queries'] = 0"),
]

# --- sizes and bounds: counts, lengths, pixels, addresses, committed records ---
def _bounds_png_header(path: Path, width: int, height: int) -> None:
    """A PNG that declares width x height pixels and holds none: the size check must refuse it unread (instant)."""
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(b"")) + chunk(b"IEND", b""))


def _bounds_committed(folder: Path, change: Callable[[dict], object]) -> None:
    """measured/modular/exhaustive/ of `folder`: the committed table of terrain 1000 and its record after `change`."""
    import json
    import shutil

    source = ROOT / "measured" / "modular" / "exhaustive" / "blocks-1000.parquet"
    target = folder / "measured" / "modular" / "exhaustive"
    target.mkdir(parents=True)
    shutil.copy(source, target / source.name)
    record = json.loads(source.with_suffix(".json").read_text())
    changed = change(record)
    (target / "blocks-1000.json").write_text(json.dumps(record if changed is None else changed))


_BOUNDS_LISTENERS: list = []  # kept open for the session: a listener closed early would refuse, not stall


def _bounds_listener(folder: Path, kind: str) -> None:
    """An HTTP server or a socket that accepts and never answers, on loopback; params.yaml's compute.address
    names it (the address of a command's --address goes the same way: ComputeConfig -> Executor)."""
    import http.server
    import socket
    import threading

    if kind == "http":
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.BaseHTTPRequestHandler)
        server.RequestHandlerClass.log_message = lambda *args: None
        threading.Thread(target=server.serve_forever, daemon=True).start()
        port = server.server_address[1]
    else:
        server = socket.socket()
        server.bind(("127.0.0.1", 0))
        server.listen(8)
        port = server.getsockname()[1]
    _BOUNDS_LISTENERS.append(server)
    document = yaml.safe_load((folder / "params.yaml").read_text())
    document["compute"]["address"] = f"tcp://127.0.0.1:{port}"
    (folder / "params.yaml").write_text(yaml.safe_dump(document))


_BOUNDS_RULES = ",".join(["0"] * 10_001)
_BOUNDS_ALLOCATION = ";".join(["0.1,0.1,0.1"] * 8)
_BOUNDS_NOT_AN_OBJECT = ("measured/modular/exhaustive/blocks-1000.json: expected a JSON object", "found a list")
_BOUNDS_UNKNOWN_KEY = ("measured/modular/exhaustive/blocks-1000.json: settings.gravity: unknown field; "
                       "expected one of",)


def _bounds_npy(path: Path, shape: tuple[int, int], height: float) -> None:
    import numpy as np

    np.save(path, np.full(shape, height))


def _bounds_vae(path: Path) -> None:
    """A tiny untrained graph VAE (latent 4) saved as `sample`/`decode` read it."""
    from robocompose.latent.model import GraphVAE, VAEConfig
    from robocompose.latent.train import save_model

    save_model(GraphVAE(VAEConfig(hidden=16, latent=4, max_nodes=30)), path)


def _bounds_gravity(record: dict) -> None:
    record["settings"]["gravity"] = 9.81


BOUNDS = [
    Case("compose modular: k zero", ("argument --k: expected an integer >= 1, found 0",),
         argv=("compose", "modular", "--terrain-seed", "1", "--k", "0")),
    # generator draws and decoded designs: bounded before anything is allocated
    Case("compose modular: samples beyond memory", ("argument --samples: expected an integer from 1 to 100,000",
                                                    "found 999999999999"),
         argv=("compose", "modular", "--terrain-seed", "1", "--samples", "999999999999")),
    Case("sample: n beyond memory", ("argument --n: expected an integer from 1 to 10,000", "found 99999999999"),
         argv=("sample", "--n", "99999999999", "--model", "{tmp}/vae.pt")),
    Case("verify-committed: sample zero", ("argument --sample: expected an integer >= 1, found 0",),
         argv=("modular", "verify-committed", "--sample", "0")),
    # committed exhaustive records: one check for every reader
    Case("modular criterion: a record that is a list", _BOUNDS_NOT_AN_OBJECT, argv=("modular", "criterion"),
         setup=lambda tmp: _bounds_committed(tmp, lambda record: [record])),
    Case("verify-committed: a record that is a list", _BOUNDS_NOT_AN_OBJECT, argv=("modular", "verify-committed"),
         setup=lambda tmp: _bounds_committed(tmp, lambda record: [record])),
    Case("modular_exhaustive: a record that is a list", _BOUNDS_NOT_AN_OBJECT, stage="modular_exhaustive",
         setup=lambda tmp: _bounds_committed(tmp, lambda record: [record])),
    Case("modular criterion: a record with an unknown settings key", _BOUNDS_UNKNOWN_KEY, argv=("modular", "criterion"),
         setup=lambda tmp: _bounds_committed(tmp, _bounds_gravity)),
    Case("verify-committed: a record with an unknown settings key", _BOUNDS_UNKNOWN_KEY,
         argv=("modular", "verify-committed"), setup=lambda tmp: _bounds_committed(tmp, _bounds_gravity)),
    Case("modular exhaustive: a record with an unknown settings key", _BOUNDS_UNKNOWN_KEY,
         argv=("modular", "exhaustive", "--terrain-seed", "1000"),
         setup=lambda tmp: _bounds_committed(tmp, _bounds_gravity)),
    Case("modular_exhaustive: a record with an unknown settings key", _BOUNDS_UNKNOWN_KEY, stage="modular_exhaustive",
         setup=lambda tmp: _bounds_committed(tmp, _bounds_gravity)),
    Case("modular criterion: a record without its physics digest",
         ("blocks-1000.json: physics_digest: missing field",), argv=("modular", "criterion"),
         setup=lambda tmp: _bounds_committed(tmp, lambda record: {k: v for k, v in record.items()
                                                                  if k != "physics_digest"})),
    # rule sequences: one parser, one limit
    Case("derive: 10,001 rules", ("--rules: rule sequence of 10001 rules, expected at most 200",),
         argv=("derive", "--rules", _BOUNDS_RULES)),
    Case("evaluate: 10,001 rules", ("--rules: rule sequence of 10001 rules, expected at most 200",),
         argv=("evaluate", "--rules", _BOUNDS_RULES, "--task", "flat")),
    Case("encode: 10,001 rules", ("--rules: rule sequence of 10001 rules, expected at most 200",),
         argv=("encode", "--rules", _BOUNDS_RULES, "--model", "{tmp}/vae.pt"),
         setup=lambda tmp: _bounds_vae(tmp / "vae.pt")),
    # an empty list is not "all of them"
    Case("evaluator-fidelity: empty --rungs", ("--rungs '': expected one or more comma-separated ladder rungs",),
         argv=("evaluator-fidelity", "measure", "--rungs", "")),
    Case("evaluator-fidelity: empty --tasks", ("--tasks ',': expected one or more comma-separated task names",),
         argv=("evaluator-fidelity", "measure", "--tasks", ",")),
    Case("evaluator-fidelity: an empty item in --designs", ("--designs 'a,,b': expected comma-separated design "
                                                             "names, found an empty item",),
         argv=("evaluator-fidelity", "measure", "--designs", "a,,b")),
    # enumeration that can never finish
    Case("enumerate: min_links no design reaches", ("enumerate.min_links: 100 links", "no new valid design among "
                                                    "the last 5,000 candidates"),
         stage="enumerate", change="doc['enumerate']['min_links'] = 100", slow=True),
    Case("enumerate: max_depth no derivation completes in", ("enumerate.max_depth: 2 rules, expected enough for "
                                                             "derivations to complete",),
         stage="enumerate", change="doc['enumerate']['max_depth'] = 2", slow=True),
    # Dask addresses that are no scheduler: one line within 10 s (the connect timeout is 5 s)
    Case("enumerate: an HTTP server as the Dask address", ("no Dask scheduler answered at 'tcp://127.0.0.1:",
                                                           "within 5 s"),
         argv=("enumerate", "--n", "2", "--out", "{tmp}/d.parquet"), setup=lambda tmp: _bounds_listener(tmp, "http"),
         slow=True),
    Case("enumerate: a silent listener as the Dask address", ("no Dask scheduler answered at 'tcp://127.0.0.1:",
                                                              "within 5 s"),
         argv=("enumerate", "--n", "2", "--out", "{tmp}/d.parquet"), setup=lambda tmp: _bounds_listener(tmp, "tcp"),
         slow=True),
    Case("enumerate stage: a silent listener as compute.address", ("no Dask scheduler answered at 'tcp://127.0.0.1:",
                                                                   "within 5 s"),
         stage="enumerate", setup=lambda tmp: _bounds_listener(tmp, "tcp"), slow=True),
    Case("enumerate: nothing listens at the Dask address", ("no Dask scheduler answered at 'tcp://127.0.0.1:1'",),
         argv=("enumerate", "--n", "2", "--out", "{tmp}/d.parquet", "--address", "tcp://127.0.0.1:1"), slow=True),
    # label PNGs over the pixel limit (15000 x 15000 > 12000 x 12000), refused before decoding
    Case("teams coverage: a 15000 x 15000 label PNG", ("chip.png: more than 144,000,000 pixels",),
         argv=("teams", "coverage", "--chip", "{tmp}/chip.png", "--allocation", _BOUNDS_ALLOCATION),
         setup=lambda tmp: _bounds_png_header(tmp / "chip.png", 15000, 15000)),
    Case("teams nsga2: a 15000 x 15000 label PNG", ("chip.png: more than 144,000,000 pixels",),
         argv=("teams", "nsga2", "--chip", "{tmp}/chip.png"),
         setup=lambda tmp: _bounds_png_header(tmp / "chip.png", 15000, 15000)),
    Case("compose teams: a PNG declaring 15000 x 15000", ("chip.png: more than 144,000,000 pixels",),
         argv=("compose", "teams", "--chip", "{tmp}/chip.png"),
         setup=lambda tmp: _bounds_png_header(tmp / "chip.png", 15000, 15000)),
    Case("decompose: a 15000 x 15000 label PNG in teams.chips.directory",
         ("labels/big.png: more than 144,000,000 pixels",),
         stage="decompose", change="doc['teams']['chips']['directory'] = 'labels'",
         setup=lambda tmp: _bounds_png_header(tmp / "labels" / "big.png", 15000, 15000)),
    # ported from the command tests (tests/*/test_cli.py): counts and ranges a command checks itself
    Case("teams nsga2: regions beyond 64", ("--regions: expected an integer in 1..64, found 100000",),
         argv=("teams", "nsga2", "--synthetic-seed", "0", "--regions", "100000")),
    Case("teams coverage: a fraction above 1", ("--allocation: region 0, ground: expected a fraction in [0, 1], "
                                                "found 2",),
         argv=("teams", "coverage", "--synthetic-seed", "0", "--regions", "3", "--allocation", "2,2,2;0,0,0;0,0,0")),
    Case("teams coverage: fractions summing above 1", ("--allocation: the ground fractions sum to 1.1",
                                                       "expected at most 1"),
         argv=("teams", "coverage", "--synthetic-seed", "0", "--regions", "3", "--allocation",
               "0.5,0,0;0.6,0,0;0,0,0")),
    Case("teams coverage: rows for other regions", ("--allocation has 2 rows, expected one per region (--regions 3)",),
         argv=("teams", "coverage", "--synthetic-seed", "0", "--regions", "3", "--allocation", "0.1,0,0;0,0,0")),
    Case("compose modular: heights above the params' range", ("--heightmap {tmp}/map.npy: heights expected in [0, "
                                                              "0.4] m", "found [0.5, 0.5]"),
         argv=("compose", "modular", "--heightmap", "{tmp}/map.npy"),
         setup=lambda tmp: _bounds_npy(tmp / "map.npy", (50, 20), 0.5)),
    Case("compose modular: a height map of another shape", ("--heightmap {tmp}/map.npy: expected shape (50, 20)",
                                                            "found (49, 20)"),
         argv=("compose", "modular", "--heightmap", "{tmp}/map.npy"),
         setup=lambda tmp: _bounds_npy(tmp / "map.npy", (49, 20), 0.0)),
    Case("decode: a latent of another size", ("--z: expected 4 coordinates (the model's latent space), found 2",),
         argv=("decode", "--z", "0.1,0.2", "--model", "{tmp}/vae.pt"),
         setup=lambda tmp: _bounds_vae(tmp / "vae.pt")),
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
