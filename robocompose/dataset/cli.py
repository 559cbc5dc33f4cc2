"""`robocompose enumerate`: the grammar dataset (designs with contact features) from the command line."""

from __future__ import annotations

import argparse
import json

from robocompose.arguments import add_compute_arguments, non_negative_int, output_file, positive_int


def register(subparsers: argparse._SubParsersAction) -> None:
    enum = subparsers.add_parser("enumerate", help="enumerate grammar designs with contact features to parquet")
    enum.add_argument("--n", type=positive_int, required=True, help="distinct valid designs to collect")
    enum.add_argument("--seed", type=non_negative_int, default=0)
    enum.add_argument("--out", type=output_file(".parquet", "parquet"), required=True, help="output .parquet path")
    enum.add_argument("--params", help="params file whose `compute` section is used (default: params.yaml if there "
                      "is one, else local processes on all cores); the output does not depend on it")
    add_compute_arguments(enum)
    enum.set_defaults(handler=_enumerate)


def _enumerate(args: argparse.Namespace) -> int:
    from robocompose.arguments import command_compute
    from robocompose.dataset.enumerate import EnumerateConfig, enumerate_designs
    from robocompose.io import write_table

    with command_compute(args, args.params).executor() as executor:
        designs, stats = enumerate_designs(EnumerateConfig(n=args.n, seed=args.seed), executor)
    write_table(designs, args.out, "designs")
    print(json.dumps({"out": str(args.out), **stats.as_dict()}))
    return 0
