"""What the rules can place where, read off `rules.RULES`: the tokens of bodies, mounts and limb links.

RoboGrammar's rules build a chain of bodies; a body may carry one mirrored pair of limb mounts, and a
mount carries a chain of limb links. Which tokens fill each of these places follows from the rules'
attributes (link shapes, joint rotations and axes), so this module reads them from the rule data: a
changed rule (a new limb joint, another lift angle, a longer body) changes the tokens, the decoder's
masks (`latent/constraints.py`) and the rule sequences built for decoded designs. A rule set whose
*shape* differs (no mirrored pair, more than one mount rule) fails here, naming the rule it expected.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

from robocompose.grammar.rules import RULES, EdgeAttrs, Rule
from robocompose.grammar.tree import ROOT_JOINT, classify_joint, classify_link, mirror_joint, mirrored, token_of


def _one(what: str, matches: list[int]) -> int:
    if len(matches) != 1:
        raise ValueError(f"grammar: expected exactly one rule that {what}, found rules {matches}")
    return matches[0]


def _requires(rule: Rule, label: str) -> bool:
    return any(n.require_label == label for n in rule.lhs_nodes)


def _removes(rule: Rule, label: str) -> bool:
    return any(n.require_label == label and not n.rhs for n in rule.lhs_nodes)


def _creates(rule: Rule, label: str) -> bool:
    return any(not n.lhs and n.attrs.get("label") == label for n in rule.nodes)


def _shape_rules(label: str) -> list[int]:
    """Rules that turn a node labelled `label` into a link (they set its shape)."""
    return [r for r, rule in enumerate(RULES)
            if any(n.require_label == label and n.lhs and n.rhs and "shape" in n.attrs for n in rule.nodes)]


def _link_type(rule: Rule, label: str) -> int:
    node = next(n for n in rule.nodes if n.require_label == label and "shape" in n.attrs)
    return classify_link(node.attrs["length"], node.attrs["radius"])


def _joint_rules(label: str) -> list[int]:
    """Rules that turn an edge labelled `label` into a joint."""
    return [r for r, rule in enumerate(RULES)
            if any(e.side == "L" and e.require_label == label for e in rule.edges)
            and any(e.side == "R" and "joint_type" in e.attrs for e in rule.edges)]


def _joint(rule: Rule) -> EdgeAttrs:
    return EdgeAttrs(**next(e.attrs for e in rule.edges if e.side == "R" and "joint_type" in e.attrs))


@dataclass(frozen=True)
class Vocabulary:
    """Tokens by place, and the rules that make them (rule indices into `RULES`)."""

    root: int  # token of the first body (the root of every design tree)
    body_type: int  # link type of bodies
    next_body: dict[int, int]  # token of a following body -> rule making its joint
    limb_links: dict[int, int]  # link type of a limb link -> rule making it
    limb_joints: dict[int, int]  # joint type of a limb link -> rule making it
    mount: int  # token of a body's first limb mount
    mount_twin: int  # token of its mirrored twin
    mount_links: int  # links one mount commits to: the mount and its first limb link
    make_robot: int
    end_head: int
    append_body: int
    body_with_mounts: int
    body_without_mounts: int
    append_limb_link: int
    end_limb: int
    end_tail: int

    @property
    def limb_tokens(self) -> tuple[int, ...]:
        """Every token a limb link on a mount's unmirrored side may have."""
        return tuple(token_of(lt, j) for lt in sorted(self.limb_links) for j in sorted(self.limb_joints))

    def mirror(self, token: int) -> int:
        """The token of the twin of a limb link with `token` on the mirrored side."""
        link_type, joint = divmod(token, 14)
        return token_of(link_type, mirror_joint(joint, link_type))


@cache
def vocabulary() -> Vocabulary:
    """The vocabulary of `RULES` (computed once)."""
    rule_of = {name: _one(what, [r for r, rule in enumerate(RULES) if test(rule)]) for name, what, test in [
        ("make_robot", "rewrites the start symbol", lambda r: _requires(r, "robot")),
        ("end_head", "removes the head", lambda r: _removes(r, "head")),
        ("append_body", "inserts a body before the tail", lambda r: _requires(r, "tail") and _creates(r, "body")),
        ("end_tail", "removes the tail", lambda r: _removes(r, "tail")),
        ("append_limb_link", "adds a limb link", lambda r: _requires(r, "limb") and _creates(r, "limb_link")),
        ("end_limb", "ends a limb", lambda r: _removes(r, "limb")),
    ]}
    bodies = _shape_rules("body")
    mount_rule = _one("gives a body limb mounts", [r for r in bodies if len(RULES[r].nodes) > 1])
    plain_body = _one("finishes a body without mounts", [r for r in bodies if r != mount_rule])
    body_type = _link_type(RULES[plain_body], "body")
    if _link_type(RULES[mount_rule], "body") != body_type:
        raise ValueError(f"grammar: rules {mount_rule} and {plain_body} make bodies of different shapes")
    limb_links = {_link_type(RULES[r], "limb_link"): r for r in _shape_rules("limb_link")}
    limb_joints = {classify_joint(_joint(RULES[r]).joint_type, _joint(RULES[r]).joint_rot,
                                  _joint(RULES[r]).joint_axis, min(limb_links)): r for r in _joint_rules("limb_joint")}
    next_body = {token_of(body_type, classify_joint(_joint(RULES[r]).joint_type, _joint(RULES[r]).joint_rot,
                                                    _joint(RULES[r]).joint_axis, body_type)): r
                 for r in _joint_rules("body_joint")}

    # The mount rule: a new terminal link joined to the body by two fixed edges, the second mirrored.
    rule = RULES[mount_rule]
    mount_node = _one_node(rule)
    edges = [e for e in rule.edges if e.side == "R" and e.head == mount_node.name]
    if [e.attrs.get("mirror", False) for e in edges] != [False, True]:
        raise ValueError(f"grammar: rule {mount_rule} ({rule.name}) should join its mount by a plain and a "
                         "mirrored edge")
    mount_type = classify_link(mount_node.attrs["length"], mount_node.attrs["radius"])
    plain, twin = (EdgeAttrs(**e.attrs) for e in edges)
    twin_rot, twin_axis = mirrored(twin.joint_rot, twin.joint_axis)
    # A mount commits to itself and to the node(s) the rule hangs under it that always become one link.
    below = [n for n in rule.nodes if not n.lhs and n.attrs.get("label") == "limb_link"]
    return Vocabulary(
        root=token_of(body_type, ROOT_JOINT), body_type=body_type, next_body=next_body, limb_links=limb_links,
        limb_joints=limb_joints,
        mount=token_of(mount_type, classify_joint(plain.joint_type, plain.joint_rot, plain.joint_axis, mount_type)),
        mount_twin=token_of(mount_type, classify_joint(twin.joint_type, twin_rot, twin_axis, mount_type)),
        mount_links=1 + len(below), body_with_mounts=mount_rule, body_without_mounts=plain_body, **rule_of)


def _one_node(rule: Rule):
    """The mount: the rule's one new node that is a finished link (a shape, no label)."""
    nodes = [n for n in rule.nodes if not n.lhs and "shape" in n.attrs and not n.attrs.get("label")]
    if len(nodes) != 1:
        raise ValueError(f"grammar: rule {rule.name} should create exactly one finished mount link, found {len(nodes)}")
    return nodes[0]
