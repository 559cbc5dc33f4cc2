"""Decoding under constraints: which trees the decoder may build, step by step, and their rule sequences.

The decoder builds a tree depth first: at the current node it either expands (adds a child with a
label) or stops (returns to the parent). A `Walk` follows that process and says, at every step, which
decisions and labels are allowed, so that every finished walk is a complete design:

- `grammar`: exactly the trees RoboGrammar's rules derive. A body link has, in this child order, an
  optional mirrored limb-mount pair (token 29, then its twin 30) and an optional next body at its far
  end (a body link with a fixed/roll/swing/lift joint); a mount carries one limb chain (each limb link
  at most one child, joints from the limb-joint rules); the twin mount's subtree is the mirror image
  of the first, so it is forced step by step. A node budget (`max_nodes`) counts the nodes an
  expansion commits to (a mount pair commits four), so a walk never has to break off.
- `tree`: any tree over the vocabulary with at most 4 neighbours per node (the no-grammar ablation's
  own generator): the root has the root joint, every other node a real joint.

`grammar_rules(tree)` builds the rule sequence of a grammar tree constructively: one body at a time,
each non-terminal finished before the next is made, so that every rule's first match is the only one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from robocompose.grammar.tree import BODY_LINK_TYPE, N_TOKENS, DesignTree, split_token, token_of

KINDS = ("grammar", "tree")
ROOT_BODY = token_of(BODY_LINK_TYPE, 0)  # 14
MOUNT, MOUNT_TWIN = token_of(2, 1), token_of(2, 2)  # 29, 30
# Body joints of the rules make_{fixed,roll,swing,lift}_body_joint (10..13) -> joint types 1, 3, 4, 5.
BODY_JOINT_RULE = {token_of(BODY_LINK_TYPE, j): r for j, r in ((1, 10), (3, 11), (4, 12), (5, 13))}
# Limb joints of rules 14..19 (left roll, right roll, swing, acute/obtuse/backwards lift) -> joint types.
LIMB_JOINT_RULE = {6: 14, 7: 15, 4: 16, 8: 17, 10: 18, 12: 19}
LIMB_LINK_RULE = {2: 8, 0: 9}  # link type -> make_normal_limb_link / make_long_limb_link
# Joint type seen through the body's mirror plane (rule 2's mirrored mount edge).
MIRROR_JOINT = {4: 4, 6: 7, 7: 6, 8: 9, 9: 8, 10: 11, 11: 10, 12: 13, 13: 12}
LEFT_LIMB = tuple(token_of(lt, j) for lt in sorted(LIMB_LINK_RULE) for j in sorted(LIMB_JOINT_RULE))


def mirror_token(token: int) -> int:
    link_type, joint = split_token(token)
    return token_of(link_type, MIRROR_JOINT[joint])


def _mask(tokens) -> np.ndarray:
    out = np.zeros(N_TOKENS, dtype=bool)
    out[list(tokens)] = True
    return out


_BODY_CHILD = _mask(BODY_JOINT_RULE)
_LEFT_LIMB = _mask(LEFT_LIMB)
_NONE = _mask(())
_TREE_ROOT = _mask(token_of(lt, 0) for lt in range(3))
_TREE_CHILD = ~_TREE_ROOT
MAX_NEIGHBOURS = 4


@dataclass
class Walk:
    """A tree under construction in depth-first order, with the constraints of `kind` at each step."""

    kind: str
    max_nodes: int
    parents: list[int] = field(default_factory=list)
    tokens: list[int] = field(default_factory=list)
    children: list[list[int]] = field(default_factory=list)
    current: int = -1  # -1 before the root is placed and after the walk has returned from it
    twin: dict[int, int] = field(default_factory=dict)  # grammar: mirrored node -> its unmirrored twin
    committed: int = 0  # nodes placed plus nodes already promised (mirror twins, a mount's first limb)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"constraints must be one of {KINDS}, got {self.kind!r}")

    @property
    def done(self) -> bool:
        return bool(self.tokens) and self.current == -1

    def options(self) -> tuple[bool, bool, np.ndarray]:
        """(may stop, may expand, labels allowed for a new child) at the current node."""
        x = self.current
        kids = [self.tokens[c] for c in self.children[x]]
        if self.kind == "tree":
            room = len(kids) < MAX_NEIGHBOURS - (x > 0) and len(self.tokens) < self.max_nodes
            return True, room, _TREE_CHILD if room else _NONE
        if x in self.twin:  # mirrored side: copy the twin's next decision
            twin_kids = self.children[self.twin[x]]
            if len(kids) < len(twin_kids):
                return False, True, _mask([mirror_token(self.tokens[twin_kids[len(kids)]])])
            return True, False, _NONE
        free = self.max_nodes - self.committed
        token = self.tokens[x]
        if split_token(token)[0] == BODY_LINK_TYPE:
            if kids == [MOUNT]:
                return False, True, _mask([MOUNT_TWIN])
            if kids and split_token(kids[-1])[0] == BODY_LINK_TYPE:
                return True, False, _NONE
            labels = _BODY_CHILD.copy() if free >= 1 else _NONE.copy()
            if not kids and free >= 4:
                labels[MOUNT] = True
            return True, bool(labels.any()), labels
        if token == MOUNT:
            return (True, False, _NONE) if kids else (False, True, _LEFT_LIMB)
        if kids:  # a limb link on the unmirrored side: at most one child
            return True, False, _NONE
        return True, free >= 2, _LEFT_LIMB if free >= 2 else _NONE

    def root_labels(self) -> np.ndarray:
        return _mask([ROOT_BODY]) if self.kind == "grammar" else _TREE_ROOT

    def push(self, token: int) -> None:
        """Add a child with `token` to the current node (or place the root) and move to it."""
        allowed = self.root_labels() if not self.tokens else self.options()[2]
        if self.done or not allowed[token]:
            raise ValueError(f"token {token} is not allowed here (node {self.current}, tokens {self.tokens})")
        x, node = self.current, len(self.tokens)
        self.parents.append(x)
        self.tokens.append(token)
        self.children.append([])
        if x >= 0:
            self.children[x].append(node)
        self.committed += self._cost(x, token)
        if self.kind == "grammar" and x >= 0:
            if x in self.twin:
                self.twin[node] = self.children[self.twin[x]][len(self.children[x]) - 1]
            elif token == MOUNT_TWIN:
                self.twin[node] = self.children[x][0]
        self.current = node

    def _cost(self, x: int, token: int) -> int:
        if self.kind == "tree" or x < 0:
            return 1
        if x in self.twin or token == MOUNT_TWIN or self.tokens[x] == MOUNT:
            return 0  # promised when the mount pair (or the twin's link) was placed
        return {MOUNT: 4}.get(token, 2 if split_token(self.tokens[x])[0] != BODY_LINK_TYPE else 1)

    def pop(self) -> None:
        """Stop at the current node: return to its parent (-1 after the root: the walk is done)."""
        if not self.options()[0]:
            raise ValueError(f"node {self.current} may not stop here (tokens {self.tokens})")
        self.current = self.parents[self.current]

    def tree(self) -> DesignTree:
        """The finished walk as a design tree (breadth-first, as the dataset stores trees)."""
        if not self.done:
            raise ValueError("the walk is not finished")
        order, parents = [0], [-1]
        for node in order:
            for c in self.children[node]:
                parents.append(order.index(node))
                order.append(c)
        return DesignTree(tuple(parents), tuple(self.tokens[i] for i in order))


def ordered_children(tree: DesignTree, kind: str) -> list[list[int]]:
    """Each node's children in the decoder's order: grammar (mount, twin, body); tree (canonical form)."""
    kids: list[list[int]] = [[] for _ in tree.tokens]
    for i, p in enumerate(tree.parents[1:], 1):
        kids[p].append(i)
    if kind == "grammar":
        key = lambda c: (split_token(tree.tokens[c])[0] == BODY_LINK_TYPE, tree.tokens[c])  # noqa: E731
    else:
        key = tree.canonical
    return [sorted(k, key=key) for k in kids]


@dataclass(frozen=True)
class Replay:
    """A tree walked in decoder order: what the decoder must predict at each step, and what it may."""

    preorder: list[int]  # tree nodes in depth-first order
    parents: list[int]  # in preorder numbering
    tokens: list[int]
    children: list[list[int]]  # in preorder numbering, decoder order
    label_masks: np.ndarray  # (n, 42) labels allowed for each node when it is placed
    stop_free: np.ndarray  # (2n - 1,) both decisions allowed; predictions in order (node, k) by preorder

    @cached_property
    def arrays(self):  # -> batch.TreeArrays
        """This tree's share of a training batch, computed once (`batch.tree_arrays`); `collate` concatenates."""
        from robocompose.latent.batch import tree_arrays

        return tree_arrays(self)


def replay(tree: DesignTree, kind: str, max_nodes: int) -> Replay:
    """Walk `tree` in decoder order; ValueError if the constraints of `kind` do not allow it."""
    kids = ordered_children(tree, kind)
    preorder, stack = [], [0]
    while stack:
        node = stack.pop()
        preorder.append(node)
        stack.extend(reversed(kids[node]))
    new = {old: i for i, old in enumerate(preorder)}
    walk = Walk(kind, max_nodes)
    masks, stop_free = [walk.root_labels()], []
    walk.push(tree.tokens[0])

    def visit(old: int) -> None:
        for c in kids[old]:
            may_stop, may_expand, labels = walk.options()
            if not may_expand or not labels[tree.tokens[c]]:
                raise ValueError(f"{kind} constraints do not allow token {tree.tokens[c]} under node {old}")
            stop_free.append(may_stop and may_expand)
            masks.append(labels)
            walk.push(tree.tokens[c])
            visit(c)
        may_stop, may_expand, _ = walk.options()
        if not may_stop:
            raise ValueError(f"{kind} constraints do not allow node {old} (token {tree.tokens[old]}) to end here")
        stop_free.append(may_stop and may_expand)
        walk.pop()

    visit(0)
    # The walk numbers nodes in the order it places them, which is the preorder.
    return Replay(preorder, [new[tree.parents[o]] if o else -1 for o in preorder],
                  [tree.tokens[o] for o in preorder], [[new[c] for c in kids[o]] for o in preorder],
                  np.stack(masks), np.array(stop_free))


def stop_predictions(children: list[list[int]]) -> list[tuple[int, int]]:
    """(node, k) of every stop/expand decision in decoding order (k = children placed so far)."""
    out: list[tuple[int, int]] = []

    def visit(x: int) -> None:
        for k, c in enumerate(children[x]):
            out.append((x, k))
            visit(c)
        out.append((x, len(children[x])))

    visit(0)
    return out


def grammar_rules(tree: DesignTree) -> tuple[int, ...]:
    """A rule sequence that derives `tree` (ValueError if the grammar cannot make it)."""
    r = replay(tree, "grammar", max_nodes=len(tree.tokens))
    rules = [0, 7]  # make_robot, end_head
    body = 0
    while True:
        kids = r.children[body]
        mounts = [c for c in kids if r.tokens[c] == MOUNT]
        nxt = [c for c in kids if split_token(r.tokens[c])[0] == BODY_LINK_TYPE]
        rules.append(2 if mounts else 3)  # make_body_with_legs / make_body_without_legs
        if mounts:
            link = r.children[mounts[0]][0]
            first = True
            while True:
                if not first:
                    rules.append(4)  # append_limb_link
                link_type, joint = split_token(r.tokens[link])
                rules += [LIMB_JOINT_RULE[joint], LIMB_LINK_RULE[link_type]]
                first = False
                if not r.children[link]:
                    break
                link = r.children[link][0]
            rules.append(5)  # end_limb
        if not nxt:
            rules.append(6)  # end_tail
            return tuple(rules)
        # The joint to the next body is set on the body -> tail edge before the body is inserted there.
        rules += [BODY_JOINT_RULE[r.tokens[nxt[0]]], 1]
        body = nxt[0]


def is_derivable(tree: DesignTree) -> bool:
    try:
        replay(tree, "grammar", max_nodes=len(tree.tokens))
    except ValueError:
        return False
    return True

