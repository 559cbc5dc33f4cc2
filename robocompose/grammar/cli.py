"""`robocompose derive`: a rule sequence replayed into a design (printed as JSON)."""

from __future__ import annotations

import argparse
import json


def register(subparsers: argparse._SubParsersAction) -> None:
    derive = subparsers.add_parser("derive", help="derive a design from a rule sequence; prints JSON")
    derive.add_argument("--rules", required=True, help="comma-separated rule indices, e.g. 0,7,1,13,...")
    derive.set_defaults(handler=_derive)


def _derive(args: argparse.Namespace) -> int:
    from robocompose.grammar.derivation import derive, parse_rules

    derivation = derive(parse_rules(args.rules, "--rules"))
    tree = derivation.tree
    print(json.dumps({"design_id": tree.design_id, "complete": derivation.graph.complete,
                      "n_links": tree.n_links, "n_joints": tree.n_joints,
                      "parents": list(tree.parents), "tokens": list(tree.tokens)}))
    return 0
