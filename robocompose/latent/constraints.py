"""Decoding under constraints: which trees the decoder may build, step by step, and their rule sequences.

The decoder builds a tree depth first: at the current node it either expands (adds a child with a
label) or stops (returns to the parent). A `Walk` follows that process and says, at every step, which
decisions and labels are allowed, so that every finished walk is a complete design:

- `grammar` (ours): exactly the trees RoboGrammar's rules derive. A body link has, in this child order,
  an optional mirrored limb-mount pair (the mount, then its twin) and an optional next body at its far
  end; a mount carries one limb chain (each limb link at most one child); the twin mount's subtree is
  the mirror image of the first, so it is forced step by step. Which tokens fill each place is read
  from the rules (`grammar.vocabulary`). A node budget (`max_nodes`) counts the nodes an expansion
  commits to (a mount pair commits four: both mounts and their first limb links), so a walk never has
  to break off.
- `tree` (the original's): any of the 42 labels anywhere, root included, and any stop/expand decision,
  within what a tree of the representation can hold: at most 4 neighbours per node (3 children, 4 at
  the root) and `max_nodes` nodes. This is GLSO's unmasked decoding, and the no-grammar set's generator.

`grammar_rules(tree)` builds the rule sequence of a grammar tree constructively: one body at a time,
each non-terminal finished before the next is made, so that every rule's first match is the only one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from robocompose.grammar.tree import N_TOKENS, DesignTree, split_token
from robocompose.grammar.vocabulary import vocabulary

KINDS = ("grammar", "tree")
VOCABULARY = vocabulary()
ROOT_BODY, MOUNT, MOUNT_TWIN = VOCABULARY.root, VOCABULARY.mount, VOCABULARY.mount_twin
BODY_LINK_TYPE = VOCABULARY.body_type
MIRRORED_SIDES = 2  # a mount pair: the plain side and its mirror image


def mirror_token(token: int) -> int:
    return VOCABULARY.mirror(token)


def _mask(tokens) -> np.ndarray:
    out = np.zeros(N_TOKENS, dtype=bool)
    out[list(tokens)] = True
    return out


_BODY_CHILD = _mask(VOCABULARY.next_body)
_LEFT_LIMB = _mask(VOCABULARY.limb_tokens)
_NONE = _mask(())
_ANY = ~_NONE
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
            return True, room, _ANY if room else _NONE
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
            if not kids and free >= MIRRORED_SIDES * VOCABULARY.mount_links:
                labels[MOUNT] = True
            return True, bool(labels.any()), labels
        if token == MOUNT:
            return (True, False, _NONE) if kids else (False, True, _LEFT_LIMB)
        if kids:  # a limb link on the unmirrored side: at most one child
            return True, False, _NONE
        room = free >= MIRRORED_SIDES  # the link and its mirror twin
        return True, room, _LEFT_LIMB if room else _NONE

    def root_labels(self) -> np.ndarray:
        return _mask([ROOT_BODY]) if self.kind == "grammar" else _ANY

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
        if token == MOUNT:
            return MIRRORED_SIDES * VOCABULARY.mount_links
        return MIRRORED_SIDES if split_token(self.tokens[x])[0] != BODY_LINK_TYPE else 1

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


@dataclass(frozen=True, eq=False)  # compared and hashed by identity: `batch` caches its arrays per replay
class Replay:
    """A tree walked in decoder order: what the decoder must predict at each step, and what it may."""

    preorder: list[int]  # tree nodes in depth-first order
    parents: list[int]  # in preorder numbering
    tokens: list[int]
    children: list[list[int]]  # in preorder numbering, decoder order
    label_masks: np.ndarray  # (n, 42) labels allowed for each node when it is placed
    stop_free: np.ndarray  # (2n - 1,) both decisions allowed; predictions in order (node, k) by preorder


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
    v = VOCABULARY
    r = replay(tree, "grammar", max_nodes=len(tree.tokens))
    rules = [v.make_robot, v.end_head]
    body = 0
    while True:
        kids = r.children[body]
        mounts = [c for c in kids if r.tokens[c] == MOUNT]
        nxt = [c for c in kids if split_token(r.tokens[c])[0] == BODY_LINK_TYPE]
        rules.append(v.body_with_mounts if mounts else v.body_without_mounts)
        if mounts:
            link = r.children[mounts[0]][0]
            first = True
            while True:
                if not first:
                    rules.append(v.append_limb_link)
                link_type, joint = split_token(r.tokens[link])
                rules += [v.limb_joints[joint], v.limb_links[link_type]]
                first = False
                if not r.children[link]:
                    break
                link = r.children[link][0]
            rules.append(v.end_limb)
        if not nxt:
            rules.append(v.end_tail)
            return tuple(rules)
        # The joint to the next body is set on the body -> tail edge before the body is inserted there.
        rules += [v.next_body[r.tokens[nxt[0]]], v.append_body]
        body = nxt[0]


def is_derivable(tree: DesignTree) -> bool:
    try:
        replay(tree, "grammar", max_nodes=len(tree.tokens))
    except ValueError:
        return False
    return True

