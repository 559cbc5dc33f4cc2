"""DVC stage `vae_designs`: more designs for VAE training only -> data/vae_extra_designs.parquet (grammar, the
dataset's own enumeration with another seed, dataset designs removed) and data/vae_extra_nogram.parquet."""

from dataclasses import replace

import pandas as pd

from robocompose.dataset.enumerate import EnumerateConfig, enumerate_designs
from robocompose.dataset.nogram import NogramConfig, enumerate_nogram
from robocompose.fanout.compute import ComputeConfig
from robocompose.io import get_schema, read_table, write_table
from robocompose.io.timings import timed
from robocompose.latent.params import ExtraConfig
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    extra = load_section(ExtraConfig, "train_vae.extra")
    enumeration = load_section(EnumerateConfig, "enumerate")
    compute = load_section(ComputeConfig, "compute")
    designs = read_table("data/designs.parquet", "designs")
    nogram = read_table("data/designs_nogram.parquet", "designs")
    none = pd.DataFrame(columns=get_schema("designs").names)
    with timed("vae_designs") as timing, compute.executor() as executor:
        more = more_nogram = none
        if extra.n:
            more, _ = enumerate_designs(replace(enumeration, n=extra.n, seed=extra.seed), executor, "vae_designs")
            more_nogram, _ = enumerate_nogram(NogramConfig(n=extra.n, seed=extra.seed + 1), executor,
                                              enumeration.chunk, "vae_designs (nogram)")
        for table, known, path in [(more, designs, "data/vae_extra_designs.parquet"),
                                   (more_nogram, nogram, "data/vae_extra_nogram.parquet")]:
            table = table[~table["design_id"].isin(set(known["design_id"]))]
            write_table(table.reset_index(drop=True), path, "designs")
            timing[path] = len(table)


if __name__ == "__main__":
    run_stage(main)
