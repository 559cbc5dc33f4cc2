"""DVC stage `enumerate`: params -> data/designs.parquet, data/designs_nogram.parquet and their statistics."""

from robocompose.dataset.enumerate import EnumerateConfig, enumerate_designs
from robocompose.dataset.nogram import NogramConfig, enumerate_nogram
from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, write_table
from robocompose.params import load_section
from robocompose.report.timings import timed
from robocompose.stage import run_stage


def main() -> None:
    config = load_section(EnumerateConfig, "enumerate")
    nogram = load_section(NogramConfig, "nogram")
    compute = load_section(ComputeConfig, "compute")
    with timed("enumerate") as timing, compute.executor() as executor:
        designs, stats = enumerate_designs(config, executor)
        timing["designs_per_s"] = round(len(designs) / timing.elapsed(), 1)
        write_table(designs, "data/designs.parquet", "designs")
        nogram_designs, nogram_stats = enumerate_nogram(nogram, executor, config.chunk)
        write_table(nogram_designs, "data/designs_nogram.parquet", "designs")
        atomic_write_json("reports/metrics/enumerate.json", {"grammar": stats.as_dict(),
                                                              "nogram": nogram_stats.as_dict()})


if __name__ == "__main__":
    run_stage(main)
