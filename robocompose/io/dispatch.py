"""One CPU dispatch for every numeric library, so a stage gives the same bytes on every x86-64 machine.

numpy, its OpenBLAS, torch's ATen kernels, its MKL BLAS and its oneDNN convolutions each pick code for the
processor they run on (AVX-512 here, AVX2 on another machine), and the picks round differently: a committed
dvc.lock then reproduces only on processors like the one that wrote it. `PINNED` holds each library's own
switch set to one baseline, x86-64-v3 (Haswell: AVX2 + FMA), which every x86-64 server of the last decade has:

| variable                 | library                     | why this value                                         |
|--------------------------|-----------------------------|--------------------------------------------------------|
| OPENBLAS_CORETYPE        | numpy's OpenBLAS (matmul)   | Haswell kernels (SkylakeX on AVX-512 rounds otherwise)  |
| NPY_DISABLE_CPU_FEATURES | numpy's ufuncs, sorts       | no X86_V4 / AVX512 kernels (exp, log, power differ)     |
| MKL_CBWR                 | torch's MKL BLAS (Linear)   | COMPATIBLE: the one branch MKL honours on AMD too       |
| ATEN_CPU_CAPABILITY      | torch's kernels (softmax..) | avx2                                                    |
| ONEDNN_MAX_CPU_ISA       | torch's oneDNN (Conv2d)     | AVX2                                                    |

They act only when set before the libraries load, so entry points (the stage runner, the `robocompose`
command, the Prefect flow) call `pin_dispatch()`, which re-executes the process with them set unless they
already are; child processes (executor workers, a local Dask cluster, `dvc repro`'s stages) inherit them.
`python -m robocompose.io.dispatch COMMAND ...` runs any command under the pin (the Makefile's `make run`; a
Dask worker on another machine: `python -m robocompose.io.dispatch dask worker tcp://...`).

`ROBOCOMPOSE_DISPATCH=native` leaves every library its own choice (faster; bytes then depend on the
processor). A processor without the baseline (not x86-64, or no AVX2/FMA) cannot run its kernels: there the
pin is not applied, and a line on stderr says that results will differ from the committed ones.
"""

from __future__ import annotations

import functools
import hashlib
import os
import platform
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

PINNED = {
    "OPENBLAS_CORETYPE": "Haswell",
    "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",  # numpy 2.4's dispatch targets above X86_V3
    "MKL_CBWR": "COMPATIBLE",
    "ATEN_CPU_CAPABILITY": "avx2",
    "ONEDNN_MAX_CPU_ISA": "AVX2",
}
OPT_OUT = "ROBOCOMPOSE_DISPATCH"  # "native": no pin
BASELINE_FLAGS = frozenset({"avx", "avx2", "fma", "bmi1", "bmi2", "f16c", "movbe"})  # x86-64-v3, /proc/cpuinfo names


def cpu_flags(cpuinfo: Path = Path("/proc/cpuinfo")) -> frozenset[str]:
    """The processor's feature flags as Linux names them; empty where there is no /proc/cpuinfo."""
    try:
        text = cpuinfo.read_text()
    except OSError:
        return frozenset()
    line = next((row for row in text.splitlines() if row.startswith("flags")), "")
    return frozenset(line.partition(":")[2].split())


def has_baseline() -> bool:
    """True if this processor runs the pinned baseline's kernels (an x86-64 with every x86-64-v3 flag)."""
    return platform.machine().lower() in ("x86_64", "amd64") and BASELINE_FLAGS <= cpu_flags()


def pinned_environment(environment: Mapping[str, str] = os.environ) -> dict[str, str]:
    """`environment` with the pinned dispatch (PINNED overrides whatever it set)."""
    return {**environment, **PINNED}


def is_pinned(environment: Mapping[str, str] = os.environ) -> bool:
    return all(environment.get(name) == value for name, value in PINNED.items())


def dispatch_tag(environment: Mapping[str, str] = os.environ) -> str:
    """"" under the pinned dispatch; else what the libraries chose from (processor, flags, the switches set).

    A result computed outside the pin rounds differently, so keys that store results (settings digests) carry it.
    """
    if is_pinned(environment):
        return ""
    switches = ",".join(f"{name}={environment[name]}" for name in PINNED if name in environment)
    return f"native {platform.machine()} flags {_flags_digest()} {switches}".rstrip()


@functools.cache
def _flags_digest() -> str:
    return hashlib.sha256(" ".join(sorted(cpu_flags())).encode()).hexdigest()[:12]


def _pin_applies() -> bool:
    """False if the user opted out or the processor lacks the baseline (then says so on stderr)."""
    if os.environ.get(OPT_OUT) == "native":
        return False
    if not has_baseline():
        print(f"robocompose: this processor ({platform.machine()}) lacks the x86-64-v3 baseline (AVX2, FMA) the "
              "numeric libraries are pinned to: results will differ from the committed dvc.lock", file=sys.stderr)
        return False
    return True


def pin_dispatch() -> None:
    """Re-execute this process (same interpreter and arguments) with the pinned dispatch, unless it runs with it.

    Call it first thing in a process's entry point: what the process did before the call is done again.
    """
    if is_pinned() or not _pin_applies():
        return
    sys.stdout.flush()
    sys.stderr.flush()
    os.execve(sys.executable, [sys.executable, *sys.orig_argv[1:]], pinned_environment())


def run_pinned(command: Sequence[str]) -> None:
    """Replace this process by `command` (looked up on PATH) with the pinned dispatch in its environment."""
    if not command:
        raise SystemExit("usage: python -m robocompose.io.dispatch COMMAND [ARGUMENTS ...]")
    os.execvpe(command[0], list(command), pinned_environment() if _pin_applies() else dict(os.environ))


if __name__ == "__main__":
    run_pinned(sys.argv[1:])
