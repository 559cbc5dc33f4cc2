"""`robocompose derive | enumerate | render | export-urdf`: the grammar dataset from the command line."""

from __future__ import annotations

import argparse
import json

from robocompose.arguments import non_negative_int, output_file, positive_int


def register(subparsers: argparse._SubParsersAction) -> None:
    derive = subparsers.add_parser("derive", help="derive a design from a rule sequence; prints JSON")
    derive.add_argument("--rules", required=True, help="comma-separated rule indices, e.g. 0,7,1,13,...")
    derive.set_defaults(handler=_derive)

    enum = subparsers.add_parser("enumerate", help="enumerate grammar designs with contact features to parquet")
    enum.add_argument("--n", type=positive_int, required=True, help="distinct valid designs to collect")
    enum.add_argument("--seed", type=non_negative_int, default=0)
    enum.add_argument("--out", type=output_file(".parquet", "parquet"), required=True, help="output .parquet path")
    enum.add_argument("--workers", type=non_negative_int, default=0,
                      help="processes (0 = all cores); output does not depend on it")
    enum.set_defaults(handler=_enumerate)

    render = subparsers.add_parser("render", help="render a design at rest to PNG (CPU renderer)")
    render.add_argument("--rules", required=True)
    render.add_argument("--out", type=output_file(".png", "PNG"), required=True, help="output .png path")
    render.set_defaults(handler=_render)

    urdf = subparsers.add_parser("export-urdf", help="write a design as URDF")
    urdf.add_argument("--rules", required=True)
    urdf.add_argument("--out", type=output_file(".urdf", "URDF"), required=True, help="output .urdf path")
    urdf.set_defaults(handler=_export_urdf)


def _tree(rules: str):
    from robocompose.grammar.derivation import derive, parse_rules

    return derive(parse_rules(rules)).tree


def _derive(args: argparse.Namespace) -> int:
    from robocompose.grammar.derivation import derive, parse_rules

    derivation = derive(parse_rules(args.rules))
    tree = derivation.tree
    print(json.dumps({"design_id": tree.design_id, "complete": derivation.graph.complete,
                      "n_links": tree.n_links, "n_joints": tree.n_joints,
                      "parents": list(tree.parents), "tokens": list(tree.tokens)}))
    return 0


def _enumerate(args: argparse.Namespace) -> int:
    from robocompose.grammar.enumerate import EnumerateConfig, enumerate_designs
    from robocompose.io import write_table

    designs, stats = enumerate_designs(EnumerateConfig(n=args.n, seed=args.seed, workers=args.workers))
    write_table(designs, args.out, "designs")
    print(json.dumps({"out": str(args.out), **stats.as_dict()}))
    return 0


def _render(args: argparse.Namespace) -> int:
    from robocompose.sim.render import render_design

    tree = _tree(args.rules)
    print(json.dumps({"out": str(render_design(tree, args.out)), "design_id": tree.design_id}))
    return 0


def _export_urdf(args: argparse.Namespace) -> int:
    from robocompose.sim.urdf import export_urdf

    tree = _tree(args.rules)
    print(json.dumps({"out": str(export_urdf(tree, args.out)), "design_id": tree.design_id}))
    return 0
