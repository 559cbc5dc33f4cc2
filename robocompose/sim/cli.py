"""`robocompose render | export-urdf`: a grammar design as a picture or a URDF file."""

from __future__ import annotations

import argparse
import json


def register(subparsers: argparse._SubParsersAction) -> None:
    render = subparsers.add_parser("render", help="render a design at rest to PNG (CPU renderer)")
    render.add_argument("--rules", required=True)
    render.add_argument("--out", required=True)
    render.set_defaults(handler=_render)

    urdf = subparsers.add_parser("export-urdf", help="write a design as URDF")
    urdf.add_argument("--rules", required=True)
    urdf.add_argument("--out", required=True)
    urdf.set_defaults(handler=_export_urdf)


def _tree(rules: str):
    from robocompose.grammar.derivation import derive, parse_rules

    return derive(parse_rules(rules)).tree


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
