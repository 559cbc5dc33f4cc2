"""`robocompose enumerate`: the grammar dataset (designs with contact features) from the command line."""

from __future__ import annotations

import argparse
import json

from robocompose.arguments import non_negative_int, output_file, positive_int


def register(subparsers: argparse._SubParsersAction) -> None:
    enum = subparsers.add_parser("enumerate", help="enumerate grammar designs with contact features to parquet")
    enum.add_argument("--n", type=positive_int, required=True, help="distinct valid designs to collect")
    enum.add_argument("--seed", type=non_negative_int, default=0)
    enum.add_argument("--out", type=output_file(".parquet", "parquet"), required=True, help="output .parquet path")
    enum.add_argument("--workers", type=non_negative_int, default=0,
                      help="processes (0 = all cores); output does not depend on it")
    enum.add_argument("--address", default="",
                      help="a running Dask scheduler (tcp://host:8786) to fan out on instead of local processes")
    enum.set_defaults(handler=_enumerate)


def _enumerate(args: argparse.Namespace) -> int:
    from robocompose.dataset.enumerate import EnumerateConfig, enumerate_designs
    from robocompose.io import write_table

    designs, stats = enumerate_designs(EnumerateConfig(n=args.n, seed=args.seed, workers=args.workers,
                                                      address=args.address))
    write_table(designs, args.out, "designs")
    print(json.dumps({"out": str(args.out), **stats.as_dict()}))
    return 0
