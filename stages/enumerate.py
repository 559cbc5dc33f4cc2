"""DVC stage `enumerate`: params -> data/designs.parquet, data/designs_nogram.parquet, their statistics and a
gallery of the dataset (reports/plots/gallery.png)."""

from pathlib import Path

from robocompose.dataset.enumerate import EnumerateConfig, enumerate_designs
from robocompose.dataset.nogram import NogramConfig, enumerate_nogram
from robocompose.dataset.summary import GalleryConfig, draw_gallery, floor_points
from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, write_table
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    config = load_section(EnumerateConfig, "enumerate")
    nogram = load_section(NogramConfig, "nogram")
    gallery = load_section(GalleryConfig, "gallery")
    compute = load_section(ComputeConfig, "compute")
    with timed("enumerate") as timing, compute.executor() as executor:
        designs, stats = enumerate_designs(config, executor)
        timing["designs_per_s"] = round(len(designs) / timing.elapsed(), 1)
        write_table(designs, "data/designs.parquet", "designs")
        nogram_designs, nogram_stats = enumerate_nogram(nogram, executor, config.chunk)
        write_table(nogram_designs, "data/designs_nogram.parquet", "designs")
        atomic_write_json("reports/metrics/enumerate.json", {"grammar": stats.as_dict(),
                                                              "nogram": nogram_stats.as_dict(),
                                                              "floor_points": floor_points(designs)})
        draw_gallery(designs, gallery, Path("reports/plots/gallery.png"))


if __name__ == "__main__":
    run_stage(main)
