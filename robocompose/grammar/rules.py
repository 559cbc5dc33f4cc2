"""The 20 RoboGrammar rules as data, and the graph-rewriting engine that applies them.

The semantics follow RoboGrammar's own rewriting (`findMatches`, `checkRuleApplicability`, `applyRule`):
a rule is a graph whose nodes and edges belong to its left side (L), right side (R) or both; it is
applied at the *first* match, where matches are enumerated by mapping the L nodes, in rule order, to
target nodes in ascending index order. Applying a rule moves matched nodes to the end of the node list
and appends new edges, so node and edge order (and with it every later "first match") is reproduced
exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property

# Node and edge labels that make a graph incomplete.
NONTERMINAL_NODE_LABELS = frozenset({"robot", "head", "body", "tail", "limb", "limb_link"})
NONTERMINAL_EDGE_LABELS = frozenset({"body_joint", "limb_joint"})

Quaternion = tuple[float, float, float, float]  # (w, x, y, z)
IDENTITY: Quaternion = (1.0, 0.0, 0.0, 0.0)


def axis_angle(x: float, y: float, z: float, degrees: float) -> Quaternion:
    """Unit quaternion (w, x, y, z) of a rotation about a unit axis, as RoboGrammar's `axis_angle`."""
    half = math.radians(degrees) / 2
    s = math.sin(half)
    return (math.cos(half), x * s, y * s, z * s)


@dataclass(frozen=True)
class NodeAttrs:
    """A graph node: a non-terminal (label set) or a capsule link (label empty)."""

    label: str = ""
    shape: str = "none"  # "capsule" for a link
    length: float = 1.0
    radius: float = 0.05
    density: float = 1.0
    friction: float = 0.9


@dataclass(frozen=True)
class EdgeAttrs:
    """A graph edge: a non-terminal joint (label set) or a joint between two links."""

    label: str = ""
    joint_type: str = "none"  # none | fixed | hinge
    joint_pos: float = 1.0  # where along the parent the joint sits (0 = near end, 1 = far end)
    joint_rot: Quaternion = IDENTITY
    joint_axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    kp: float = 0.01
    kd: float = 0.5
    torque: float = 1.0
    mirror: bool = False


@dataclass(frozen=True)
class Graph:
    """A design graph: nodes, and edges as (tail, head, attrs) with tail -> head."""

    nodes: tuple[NodeAttrs, ...]
    edges: tuple[tuple[int, int, EdgeAttrs], ...]

    @property
    def complete(self) -> bool:
        return NONTERMINAL_NODE_LABELS.isdisjoint(self.nodes_by_label) and NONTERMINAL_EDGE_LABELS.isdisjoint(
            self.edges_by_label)

    @cached_property
    def nodes_by_label(self) -> dict[str, list[int]]:
        out: dict[str, list[int]] = {}
        for j, n in enumerate(self.nodes):
            out.setdefault(n.label, []).append(j)
        return out

    @cached_property
    def edges_by_label(self) -> dict[str, list[tuple[int, int]]]:
        """label -> (tail, head) of the edges that carry it."""
        out: dict[str, list[tuple[int, int]]] = {}
        for t, h, e in self.edges:
            out.setdefault(e.label, []).append((t, h))
        return out

    @cached_property
    def edges_between(self) -> dict[tuple[int, int], list[int]]:
        """(tail, head) -> indices of the edges between them, ascending."""
        out: dict[tuple[int, int], list[int]] = {}
        for k, (t, h, _) in enumerate(self.edges):
            out.setdefault((t, h), []).append(k)
        return out

    @cached_property
    def incident(self) -> dict[int, list[int]]:
        """node -> indices of the edges that touch it."""
        out: dict[int, list[int]] = {}
        for k, (t, h, _) in enumerate(self.edges):
            out.setdefault(t, []).append(k)
            if h != t:
                out.setdefault(h, []).append(k)
        return out

    @cached_property
    def successors(self) -> dict[int, list[int]]:
        return _sorted_neighbours((t, h) for t, h, _ in self.edges)

    @cached_property
    def predecessors(self) -> dict[int, list[int]]:
        return _sorted_neighbours((h, t) for t, h, _ in self.edges)


def _sorted_neighbours(pairs) -> dict[int, list[int]]:
    out: dict[int, set[int]] = {}
    for a, b in pairs:
        out.setdefault(a, set()).add(b)
    return {a: sorted(bs) for a, bs in out.items()}


START_GRAPH = Graph(nodes=(NodeAttrs(label="robot"),), edges=())


@dataclass(frozen=True)
class RuleNode:
    name: str
    lhs: bool
    rhs: bool
    require_label: str = ""
    attrs: dict = field(default_factory=dict)  # non-default attributes the rule writes on the node


@dataclass(frozen=True)
class RuleEdge:
    tail: str
    head: str
    side: str  # "L" or "R"
    require_label: str = ""
    edge_id: str = ""  # an L and an R edge with the same id keep the matched edges (re-attached)
    attrs: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Rule:
    """One grammar rule; `nodes` are in the order RoboGrammar's DOT file first mentions them."""

    name: str
    nodes: tuple[RuleNode, ...]
    edges: tuple[RuleEdge, ...]

    @cached_property
    def lhs_nodes(self) -> list[RuleNode]:
        return [n for n in self.nodes if n.lhs]

    @cached_property
    def match_key(self) -> tuple:
        """Rules with equal keys have the same applicable matches (same L pattern, same removals)."""
        return (tuple((n.require_label, n.rhs) for n in self.lhs_nodes), tuple(self.lhs_edges))

    @cached_property
    def removed(self) -> tuple[int, ...]:
        """Positions in `lhs_nodes` of the nodes the rule deletes."""
        return tuple(i for i, n in enumerate(self.lhs_nodes) if not n.rhs)

    @cached_property
    def required_labels(self) -> tuple[frozenset[str], frozenset[str]]:
        """(node labels, edge labels) a target graph must contain for the rule to match at all."""
        return (frozenset(n.require_label for n in self.lhs_nodes if n.require_label),
                frozenset(label for _, _, label in self.lhs_edges if label))

    @cached_property
    def lhs_edges(self) -> list[tuple[int, int, str]]:
        """L edges as (tail, head, required label) with tail and head indexing `lhs_nodes`."""
        pos = {n.name: i for i, n in enumerate(self.lhs_nodes)}
        return [(pos[e.tail], pos[e.head], e.require_label) for e in self.edges if e.side == "L"]


def _lhs(name: str, require: str = "") -> RuleNode:
    return RuleNode(name, lhs=True, rhs=False, require_label=require)


def _both(name: str, require: str = "", **attrs) -> RuleNode:
    return RuleNode(name, lhs=True, rhs=True, require_label=require, attrs=attrs)


def _new(name: str, **attrs) -> RuleNode:
    return RuleNode(name, lhs=False, rhs=True, attrs=attrs)


def _body_joint_rule(name: str, **attrs) -> Rule:
    return Rule(
        name,
        (_both("parent"), _both("child")),
        (
            RuleEdge("parent", "child", "L", require_label="body_joint"),
            RuleEdge("parent", "child", "R", attrs=attrs),
        ),
    )


def _limb_joint_rule(name: str, **attrs) -> Rule:
    return Rule(
        name,
        (_both("parent"), _both("child")),
        (
            RuleEdge("parent", "child", "L", require_label="limb_joint"),
            RuleEdge("parent", "child", "R", attrs=attrs),
        ),
    )


_BODY = dict(shape="capsule", length=0.15, radius=0.045, density=3.0)
_MOUNT = dict(shape="capsule", length=0.10, radius=0.025)

RULES: tuple[Rule, ...] = (
    Rule(  # 0
        "make_robot",
        (_lhs("robot", "robot"), _new("head", label="head"), _new("body", label="body"),
         _new("tail", label="tail")),
        (RuleEdge("head", "body", "R", attrs=dict(label="body_joint")),
         RuleEdge("body", "tail", "R", attrs=dict(label="body_joint"))),
    ),
    Rule(  # 1
        "append_body",
        (_both("tail", "tail", label="tail"), _both("parent"), _new("body", label="body")),
        (RuleEdge("parent", "tail", "L", edge_id="parent_edges"),
         RuleEdge("parent", "body", "R", edge_id="parent_edges"),
         RuleEdge("body", "tail", "R", attrs=dict(label="body_joint"))),
    ),
    Rule(  # 2
        "make_body_with_legs",
        (_both("body", "body", **_BODY), _new("limb_mount", **_MOUNT),
         _new("limb_link", label="limb_link"), _new("limb", label="limb")),
        (RuleEdge("body", "limb_mount", "R",
                  attrs=dict(joint_type="fixed", joint_pos=0.5, joint_rot=axis_angle(0, 1, 0, 90))),
         RuleEdge("body", "limb_mount", "R",
                  attrs=dict(joint_type="fixed", joint_pos=0.5, joint_rot=axis_angle(0, 1, 0, 90),
                             mirror=True)),
         RuleEdge("limb_mount", "limb_link", "R", attrs=dict(label="limb_joint")),
         RuleEdge("limb_link", "limb", "R")),
    ),
    Rule("make_body_without_legs", (_both("body", "body", **_BODY),), ()),  # 3
    Rule(  # 4
        "append_limb_link",
        (_both("limb", "limb", label="limb"), _both("parent"), _new("limb_link", label="limb_link")),
        (RuleEdge("parent", "limb", "L"),
         RuleEdge("parent", "limb_link", "R", attrs=dict(label="limb_joint")),
         RuleEdge("limb_link", "limb", "R")),
    ),
    Rule("end_limb", (_lhs("limb", "limb"), _both("parent")), (RuleEdge("parent", "limb", "L"),)),  # 5
    Rule("end_tail", (_lhs("tail", "tail"), _both("parent")), (RuleEdge("parent", "tail", "L"),)),  # 6
    Rule("end_head", (_lhs("head", "head"), _both("child")), (RuleEdge("head", "child", "L"),)),  # 7
    Rule("make_normal_limb_link",  # 8
         (_both("limb_link", "limb_link", shape="capsule", length=0.10, radius=0.025),), ()),
    Rule("make_long_limb_link",  # 9
         (_both("limb_link", "limb_link", shape="capsule", length=0.15, radius=0.025),), ()),
    _body_joint_rule("make_fixed_body_joint", joint_type="fixed"),  # 10
    _body_joint_rule("make_roll_body_joint", joint_type="hinge", joint_axis=(1.0, 0.0, 0.0)),  # 11
    _body_joint_rule("make_swing_body_joint", joint_type="hinge", joint_axis=(0.0, 1.0, 0.0)),  # 12
    _body_joint_rule("make_lift_body_joint", joint_type="hinge", joint_axis=(0.0, 0.0, 1.0)),  # 13
    _limb_joint_rule("make_left_roll_limb_joint", joint_type="hinge",  # 14
                     joint_rot=axis_angle(0, 1, 0, -90), joint_axis=(1.0, 0.0, 0.0)),
    _limb_joint_rule("make_right_roll_limb_joint", joint_type="hinge",  # 15
                     joint_rot=axis_angle(0, 1, 0, 90), joint_axis=(1.0, 0.0, 0.0)),
    _limb_joint_rule("make_swing_limb_joint", joint_type="hinge", joint_axis=(0.0, 1.0, 0.0)),  # 16
    _limb_joint_rule("make_acute_lift_limb_joint", joint_type="hinge",  # 17
                     joint_rot=axis_angle(0, 0, 1, 120), joint_axis=(0.0, 0.0, 1.0)),
    _limb_joint_rule("make_obtuse_lift_limb_joint", joint_type="hinge",  # 18
                     joint_rot=axis_angle(0, 0, 1, 60), joint_axis=(0.0, 0.0, 1.0)),
    _limb_joint_rule("make_backwards_lift_limb_joint", joint_type="hinge",  # 19
                     joint_rot=axis_angle(0, 0, 1, -60), joint_axis=(0.0, 0.0, 1.0)),
)

# Common nodes whose rule sets a label replace the target's label; a rule that requires a label but
# sets none turns the node terminal (label ""), as `make_body_with_legs` does to its body.


def _edge_matches(edge: EdgeAttrs, require_label: str) -> bool:
    return not require_label or edge.label == require_label


def find_matches(rule: Rule, graph: Graph):
    """Yield node mappings (L node -> target node, in L order) in RoboGrammar's enumeration order.

    Candidates for an L node are tried in ascending target index, as RoboGrammar's backtracking does;
    looking them up by label or by edge only skips targets that would fail its checks.
    """
    lhs_nodes, lhs_edges = rule.lhs_nodes, rule.lhs_edges
    edges, edges_between = graph.edges, graph.edges_between
    all_nodes = range(len(graph.nodes))

    def candidates(i: int, mapping: list[int]):
        require = lhs_nodes[i].require_label
        if require:
            return graph.nodes_by_label.get(require, ())
        for tail, head, _ in lhs_edges:
            if head == i and tail < i:
                return graph.successors.get(mapping[tail], ())
            if tail == i and head < i:
                return graph.predecessors.get(mapping[head], ())
        for tail, head, label in lhs_edges:  # an edge label to a later L node: only its ends can match
            if label and i in (tail, head):
                return sorted({pair[0 if tail == i else 1] for pair in graph.edges_by_label.get(label, ())})
        return all_nodes

    def extend(mapping: list[int]):
        i = len(mapping)
        if i == len(lhs_nodes):
            yield tuple(mapping)
            return
        for j in candidates(i, mapping):
            if j in mapping:
                continue
            ok = True
            for tail, head, label in lhs_edges:
                if head == i and tail <= i:
                    key = ((j if tail == i else mapping[tail]), j)
                elif tail == i and head <= i:
                    key = (j, (j if head == i else mapping[head]))
                else:
                    continue
                between = edges_between.get(key, ())
                if not between or (label and all(edges[k][2].label != label for k in between)):
                    ok = False
                    break
            if ok:
                yield from extend([*mapping, j])

    yield from extend([])


def _matched_edges(rule: Rule, graph: Graph, mapping: tuple[int, ...]) -> list[list[int]]:
    """For each L edge, the indices of all target edges it matches (RoboGrammar's edge_mapping)."""
    return [[k for k in graph.edges_between.get((mapping[tail], mapping[head]), ())
             if _edge_matches(graph.edges[k][2], label)]
            for tail, head, label in rule.lhs_edges]


def applicable(rule: Rule, graph: Graph, mapping: tuple[int, ...]) -> bool:
    """The dangling condition: no edge outside the match may touch a node the rule removes."""
    if not rule.removed:
        return True
    in_lhs = {k for ks in _matched_edges(rule, graph, mapping) for k in ks}
    return all(k in in_lhs for i in rule.removed for k in graph.incident.get(mapping[i], ()))


def first_match(rule: Rule, graph: Graph) -> tuple[int, ...] | None:
    """The first applicable match, or None if the rule cannot be applied."""
    node_labels, edge_labels = rule.required_labels
    if not node_labels <= graph.nodes_by_label.keys() or not edge_labels <= graph.edges_by_label.keys():
        return None
    return next((m for m in find_matches(rule, graph) if applicable(rule, graph, m)), None)


def apply_rule(rule: Rule, graph: Graph, mapping: tuple[int, ...]) -> Graph:
    """Rewrite `graph` at `mapping`, ordering nodes and edges exactly as RoboGrammar's applyRule."""
    lhs_index = {n.name: i for i, n in enumerate(rule.lhs_nodes)}
    matched = set(mapping)
    nodes: list[NodeAttrs] = []
    target_to_result: dict[int, int] = {}
    rule_to_result: dict[str, int] = {}
    for j, node in enumerate(graph.nodes):  # untouched nodes keep their order
        if j not in matched:
            target_to_result[j] = len(nodes)
            nodes.append(node)
    for rn in rule.nodes:  # common nodes, in rule order, move to the end
        if rn.lhs and rn.rhs:
            j = mapping[lhs_index[rn.name]]
            node = graph.nodes[j]
            changes = {k: v for k, v in rn.attrs.items() if k != "label"}
            if rn.require_label:
                changes["label"] = rn.attrs.get("label", "")
            if changes:
                node = replace(node, **changes)
            target_to_result[j] = rule_to_result[rn.name] = len(nodes)
            nodes.append(node)
    for rn in rule.nodes:  # new nodes
        if rn.rhs and not rn.lhs:
            rule_to_result[rn.name] = len(nodes)
            nodes.append(NodeAttrs(**rn.attrs))

    edge_sets = _matched_edges(rule, graph, mapping)
    in_lhs = {k for ks in edge_sets for k in ks}
    edges = [(target_to_result[t], target_to_result[h], a)
             for k, (t, h, a) in enumerate(graph.edges) if k not in in_lhs]
    lhs_edges = [e for e in rule.edges if e.side == "L"]
    rhs_edges = [e for e in rule.edges if e.side == "R"]
    rhs_ids = {e.edge_id: e for e in rhs_edges if e.edge_id}
    for lhs_edge, ks in zip(lhs_edges, edge_sets, strict=True):  # kept edges, re-attached
        rhs_edge = rhs_ids.get(lhs_edge.edge_id) if lhs_edge.edge_id else None
        if rhs_edge is not None:
            for k in ks:
                edges.append((rule_to_result[rhs_edge.tail], rule_to_result[rhs_edge.head], graph.edges[k][2]))
    for e in rhs_edges:  # new edges
        if not e.edge_id:
            edges.append((rule_to_result[e.tail], rule_to_result[e.head], EdgeAttrs(**e.attrs)))
    return Graph(tuple(nodes), tuple(edges))
