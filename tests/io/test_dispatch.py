"""The pinned CPU dispatch: the same bytes of a training step, an MPPI episode and an ergodic optimisation whatever
dispatch the process was started with; and the re-execution that applies it."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys

import pytest

from robocompose.io import dispatch
from robocompose.io.dispatch import (
    OPT_OUT,
    PINNED,
    cpu_flags,
    dispatch_tag,
    has_baseline,
    is_pinned,
    pinned_environment,
)
from robocompose.io.provenance import settings_digest

# Digests of three dispatch-sensitive results, printed as JSON: one Adam step of the modular EG-GAN generator
# (oneDNN convolutions, MKL linear layers, batch norm, log-softmax), a short MPPI episode of a grammar robot (numpy,
# OpenBLAS, pybullet) and an ergodic optimisation of robot teams on a synthetic chip (torch).
PROBE = """
import hashlib, json
import numpy as np
import torch

def digest(*arrays):
    return hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)).hexdigest()

torch.set_num_threads(1)
results = {}
from robocompose.eggan.networks import Generator, NetworkConfig
torch.manual_seed(0)
generator = Generator((50, 20), (6, 4), NetworkConfig(latent=8, hidden=16, filters=4))
optimiser = torch.optim.Adam(generator.parameters(), lr=1e-3)
logits = generator(torch.randn(16, 8), generator.encode(torch.rand(16, 50, 20) * 0.4)).reshape(16, 6, 4)
(-torch.log_softmax(logits, -1)[..., 0].mean()).backward()
optimiser.step()
results["training_step"] = digest(*(p.detach().numpy() for p in generator.parameters()))

from robocompose.control.mppi import MPPIConfig, run_episode
from robocompose.control.world import RobotWorld
from robocompose.grammar.derivation import derive, parse_rules
from robocompose.tasks.terrains import get_task
tree = derive(parse_rules("0,7,1,13,1,2,16,12,13,6,4,19,4,17,5,3,2,16,4,5,18,9,8,9,9,8")).tree
with RobotWorld(tree, get_task("flat")) as world:
    episode = run_episode(world, MPPIConfig(samples=4, first_samples=4, horizon=4, episode=4), seed=0)
results["mppi_episode"] = digest(episode.inputs, episode.step_rewards)

from robocompose.teams.chips import synthetic_chip
from robocompose.teams.decompose import DecomposeConfig, decompose_chip
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import chip_coverage
chip = synthetic_chip(0, 1, size=60)
coverage = chip_coverage(chip, decompose_chip(chip, DecomposeConfig(n_regions=4)), CoverageConfig(iterations=10))
counts = np.zeros((2, 4, 3), dtype=np.int64)
counts[:, :, 0], counts[:, :, 1] = 1, np.arange(1, 3)[:, None]
costs, _, observations = coverage.evaluate(counts, seed=0)
results["ergodic_optimisation"] = digest(costs, observations.numpy())
print(json.dumps(results))
"""
# Every library's switch set below the pinned baseline: a dispatch every x86-64-v3 machine can run, and one
# that rounds differently from the pin (so the pin has something to override).
BELOW_BASELINE = {"OPENBLAS_CORETYPE": "Sandybridge", "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR",
                  "MKL_CBWR": "AUTO", "ATEN_CPU_CAPABILITY": "default", "ONEDNN_MAX_CPU_ISA": "AVX"}
PIN_FIRST = "from robocompose.io.dispatch import pin_dispatch\npin_dispatch()\n"


def _start(command: list[str], settings: dict[str, str]) -> subprocess.Popen:
    """`command` in an environment with none of the pinned variables but `settings`."""
    environment = {k: v for k, v in os.environ.items() if k not in PINNED and k != OPT_OUT}
    return subprocess.Popen(command, env={**environment, **settings}, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def _results(process: subprocess.Popen) -> dict[str, str]:
    out, err = process.communicate(timeout=120)
    assert process.returncode == 0, err[-2000:]
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.skipif(not has_baseline(), reason="the pin applies on x86-64-v3 processors only")
def test_pinned_runs_give_the_same_bytes_whatever_dispatch_the_process_started_with():
    python = sys.executable
    started = {  # run side by side: each is a fresh interpreter importing torch
        # make run's mechanism: the launcher, from the libraries' own (native) choice
        "launcher": _start([python, "-m", "robocompose.io.dispatch", python, "-c", PROBE], {}),
        # the stage runner's mechanism: re-executing itself, from a process started with other dispatch settings
        "re-executed": _start([python, "-c", PIN_FIRST + PROBE], BELOW_BASELINE),
        "native": _start([python, "-c", PROBE], {}),
        "below baseline": _start([python, "-c", PROBE], BELOW_BASELINE),
    }
    results = {name: _results(process) for name, process in started.items()}
    assert results["re-executed"] == results["launcher"]
    for name, digest in results["launcher"].items():  # each result does depend on the dispatch ...
        assert results["below baseline"][name] != digest, name
    if "avx512f" in cpu_flags():  # ... and on an AVX-512 machine the libraries' own choice is not the pin's
        assert results["native"] != results["launcher"]


def test_the_pin_overrides_what_the_environment_set_and_keeps_the_rest():
    environment = pinned_environment({"ATEN_CPU_CAPABILITY": "avx512", "HOME": "/home/x"})
    assert environment == {**PINNED, "HOME": "/home/x"} and is_pinned(environment)
    assert not is_pinned({**PINNED, "OPENBLAS_CORETYPE": "SkylakeX"})


def test_cpu_flags_are_read_from_cpuinfo(tmp_path):
    cpuinfo = tmp_path / "cpuinfo"
    cpuinfo.write_text("processor\t: 0\nflags\t\t: fpu avx avx2 fma\nbogomips\t: 5200\n")
    assert cpu_flags(cpuinfo) == {"fpu", "avx", "avx2", "fma"}
    assert cpu_flags(tmp_path / "absent") == frozenset()


@pytest.fixture
def execve(monkeypatch):
    """Calls of os.execve, recorded instead of made; an unpinned environment."""
    calls = []
    monkeypatch.setattr(os, "execve", lambda *args: calls.append(args))
    for name in (*PINNED, OPT_OUT):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(dispatch, "has_baseline", lambda: True)
    return calls


def test_an_unpinned_process_re_executes_itself_with_the_same_arguments_and_the_pin(execve, monkeypatch):
    monkeypatch.setenv("ATEN_CPU_CAPABILITY", "default")
    monkeypatch.setattr(sys, "orig_argv", ["python3", "-u", "stages/x.py", "full"])
    dispatch.pin_dispatch()
    (executable, argv, environment), = execve
    assert argv == [executable, "-u", "stages/x.py", "full"] and executable == sys.executable
    assert is_pinned(environment) and environment["PATH"] == os.environ["PATH"]


def test_a_pinned_or_opted_out_process_is_not_re_executed(execve, monkeypatch):
    monkeypatch.setenv(OPT_OUT, "native")
    dispatch.pin_dispatch()
    monkeypatch.delenv(OPT_OUT)
    for name, value in PINNED.items():
        monkeypatch.setenv(name, value)
    dispatch.pin_dispatch()
    assert execve == []


def test_a_processor_without_the_baseline_runs_unpinned_and_says_so(execve, monkeypatch, capsys):
    monkeypatch.setattr(dispatch, "has_baseline", lambda: False)
    dispatch.pin_dispatch()
    assert execve == []
    assert "lacks the x86-64-v3 baseline (AVX2, FMA)" in capsys.readouterr().err


@pytest.mark.parametrize(("machine", "flags", "expected"), [
    ("x86_64", {"sse2", "avx", "avx2", "fma", "bmi1", "bmi2", "f16c", "movbe", "avx512f"}, True),
    ("x86_64", {"sse2", "avx", "avx2"}, False),  # no FMA, BMI: a pre-Haswell core
    ("aarch64", {"fp", "asimd"}, False),
])
def test_the_baseline_needs_an_x86_64_with_every_v3_flag(monkeypatch, machine, flags, expected):
    monkeypatch.setattr(dispatch.platform, "machine", lambda: machine)
    monkeypatch.setattr(dispatch, "cpu_flags", lambda: frozenset(flags))
    assert has_baseline() is expected


def test_the_dispatch_tag_is_empty_under_the_pin_and_names_what_else_a_process_ran_with():
    assert dispatch_tag(PINNED) == ""
    native = dispatch_tag({})
    assert native.startswith("native ") and native != dispatch_tag({"OPENBLAS_CORETYPE": "SkylakeX"})
    assert dispatch_tag({**PINNED, "ATEN_CPU_CAPABILITY": "default"}) not in ("", native)


def test_settings_digests_keep_pinned_results_apart_from_native_ones(monkeypatch):
    settings = {"solver_iterations": 50, "dt": 1 / 240}
    for name, value in PINNED.items():
        monkeypatch.setenv(name, value)
    pinned = settings_digest(settings)
    assert pinned == hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:16]  # keys as before
    monkeypatch.delenv("MKL_CBWR")
    assert settings_digest(settings) != pinned
