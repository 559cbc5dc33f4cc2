"""`robocompose render | export-urdf`: a grammar design as a picture or a URDF file."""

from __future__ import annotations

import argparse
import json

from robocompose.arguments import output_file


def register(subparsers: argparse._SubParsersAction) -> None:
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

    return derive(parse_rules(rules, "--rules")).tree


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
