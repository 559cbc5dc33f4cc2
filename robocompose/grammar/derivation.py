"""Deriving designs from rule sequences: checked replay, uniform random derivation, graph -> tree."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace

import numpy as np

from robocompose.grammar.rules import RULES, START_GRAPH, EdgeAttrs, Graph, NodeAttrs, apply_rule, first_match
from robocompose.grammar.tree import DesignTree, classify_joint, classify_link, mirrored, token_of
from robocompose.io.errors import InputError

MAX_DEPTH = 40  # rule-sequence length limit of random derivation (RoboGrammar's search depth)
# Rules a parsed sequence may hold: 5x the enumerated designs' limit (MAX_DEPTH), above the ~100 rules of the
# largest tree the VAE decodes (50 nodes); replaying 1,000 rules takes seconds, 10,000 minutes.
MAX_RULES = 200


class DerivationError(InputError):
    """A rule sequence that does not derive a complete design; the message names the step and rule."""


@dataclass(frozen=True)
class Derivation:
    rules: tuple[int, ...]
    graph: Graph

    @property
    def tree(self) -> DesignTree:
        return graph_to_tree(self.graph)


def parse_rules(text: str, label: str = "") -> tuple[int, ...]:
    """Parse "0,7,1,..." into rule indices (at most MAX_RULES); errors name `label` (e.g. the flag) and the bad
    item."""
    where = f"{label}: " if label else ""
    count = text.count(",") + 1
    if count > MAX_RULES:
        raise DerivationError(f"{where}rule sequence of {count} rules, expected at most {MAX_RULES} (the grammar's "
                              f"designs take up to ~100; enumeration stops at {MAX_DEPTH})")
    out = []
    for k, item in enumerate(x.strip() for x in text.split(",")):
        try:
            out.append(int(item))
        except ValueError:
            raise DerivationError(f"{where}rule sequence item {k} is {item!r}, expected an integer rule "
                                  "index") from None
    return tuple(out)


def derive(rules: tuple[int, ...] | list[int], require_complete: bool = True) -> Derivation:
    """Apply `rules` in order, each at its first applicable match."""
    graph = START_GRAPH
    for step, r in enumerate(rules):
        if not 0 <= r < len(RULES):
            raise DerivationError(f"step {step}: rule {r} does not exist (rules are 0..{len(RULES) - 1})")
        match = first_match(RULES[r], graph)
        if match is None:
            raise DerivationError(f"step {step}: rule {r} ({RULES[r].name}) is not applicable here")
        graph = apply_rule(RULES[r], graph, match)
    if require_complete and not graph.complete:
        pending = sorted({n.label for n in graph.nodes if n.label} | {e.label for _, _, e in graph.edges if e.label})
        raise DerivationError(
            f"after {len(rules)} steps the design is incomplete: non-terminals {', '.join(pending)} remain"
        )
    return Derivation(tuple(rules), graph)


def applicable_rules(graph: Graph) -> list[int]:
    return [r for r, rule in enumerate(RULES) if first_match(rule, graph) is not None]


# Many rules share a left side (same matches): each distinct one is matched once per step.
_MATCH_KEYS = list(dict.fromkeys(rule.match_key for rule in RULES))
_SHARED_LEFT_SIDE = tuple(_MATCH_KEYS.index(rule.match_key) for rule in RULES)  # rule -> its left side
_LEFT_SIDES = tuple(RULES[_SHARED_LEFT_SIDE.index(k)] for k in range(len(_MATCH_KEYS)))  # one rule per left side


def random_derivation(rng: np.random.Generator, max_depth: int = MAX_DEPTH) -> Derivation | None:
    """Choose uniformly among the applicable rules until complete; None past `max_depth` rules."""
    graph, rules = START_GRAPH, []
    while not graph.complete:
        if len(rules) >= max_depth:
            return None
        matches = [first_match(rule, graph) for rule in _LEFT_SIDES]
        choices = [(r, matches[k]) for r, k in enumerate(_SHARED_LEFT_SIDE) if matches[k] is not None]
        r, match = choices[int(rng.integers(len(choices)))]
        graph = apply_rule(RULES[r], graph, match)
        rules.append(r)
    return Derivation(tuple(rules), graph)


@dataclass(frozen=True)
class Link:
    """One link of a design graph unfolded into a robot: the node it comes from, its parent link (-1 for
    the root) and the joint into it (None for the root), with the mirror flags down the path applied to the
    joint's rotation and axis."""

    node: NodeAttrs
    parent: int
    joint: EdgeAttrs | None


def unfold(graph: Graph) -> list[Link]:
    """The links of a (possibly incomplete) graph breadth-first from its root, as RoboGrammar's buildRobot
    unfolds a graph: each node reached along a path becomes one link."""
    root = 0
    for _ in range(len(graph.edges)):  # follow edges backwards to a root
        incoming = next((t for t, h, _ in graph.edges if h == root), None)
        if incoming is None:
            break
        root = incoming
    links: list[Link] = []
    queue = deque([(root, -1, None, False)])  # (node, parent link, edge attrs or None, mirrored)
    while queue:
        node, parent, edge, mirror = queue.popleft()
        if edge is not None and mirror:
            rot, axis = mirrored(edge.joint_rot, edge.joint_axis)
            edge = replace(edge, joint_rot=rot, joint_axis=axis)
        index = len(links)
        links.append(Link(graph.nodes[node], parent, edge))
        for t, h, e in graph.edges:
            if t == node:
                queue.append((h, index, e, mirror != e.mirror))
    return links


def graph_to_tree(graph: Graph) -> DesignTree:
    """Unfold a complete graph breadth-first into a design tree, as RoboGrammar's buildRobot does."""
    if not graph.complete:
        raise DerivationError("only a complete design graph can be built")
    parents, tokens = [], []
    for link in unfold(graph):
        link_type = classify_link(link.node.length, link.node.radius)
        joint_type = 0 if link.joint is None else classify_joint(
            link.joint.joint_type, link.joint.joint_rot, link.joint.joint_axis, link_type)
        parents.append(link.parent)
        tokens.append(token_of(link_type, joint_type))
    return DesignTree(tuple(parents), tuple(tokens))
