"""DVC stage `report`: every stage's outputs -> reports/report.md, reports/report.html, reports/figures/.

The report reads artifacts only; the params it quotes are read here and passed in.
"""

from pathlib import Path

from robocompose.control.mppi import MPPIConfig
from robocompose.fanout.compute import ComputeConfig
from robocompose.io.errors import InputError
from robocompose.io.timings import timed
from robocompose.params import PARAMS_FILE, load_section, read_params
from robocompose.report.build import ReportParams, build_report
from robocompose.stage import run_stage


def _section(params: dict, key: str) -> dict:
    if not isinstance(params.get(key), dict):
        raise InputError(f"{PARAMS_FILE}: missing section {key!r}")
    return params[key]


def main() -> None:
    params = read_params()
    cache = load_section(ComputeConfig, "compute").cache
    with timed("report"):
        build_report(ReportParams(mppi=load_section(MPPIConfig, "evaluation.mppi"),
                                  eval_cache=Path(cache) if cache else None, gallery=_section(params, "gallery"),
                                  train_vae=_section(params, "train_vae"), modular=_section(params, "modular")))


if __name__ == "__main__":
    run_stage(main)
