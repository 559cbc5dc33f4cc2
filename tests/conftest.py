"""Shared fixtures: the two reference designs of the RoboGrammar/GLSO papers."""

import pytest

from robocompose.evaluation.references import REFERENCE_DESIGNS
from robocompose.grammar.tree import DesignTree

FLAT_REFERENCE = REFERENCE_DESIGNS["robogrammar_flat"]
RIDGED_REFERENCE = REFERENCE_DESIGNS["robogrammar_ridged"]


@pytest.fixture(params=[FLAT_REFERENCE, RIDGED_REFERENCE], ids=["flat", "ridged"])
def reference_rules(request) -> str:
    return request.param


def reversed_siblings(tree: DesignTree) -> DesignTree:
    """The same design with every node's children in reverse order (as a decoder may order them)."""
    order, parents, queue = [], [], [(0, -1)]
    while queue:
        node, parent = queue.pop(0)
        order.append(node)
        parents.append(parent)
        queue.extend((j, len(order) - 1) for j in reversed(tree.children(node)))
    return DesignTree(tuple(parents), tuple(tree.tokens[i] for i in order))


@pytest.fixture
def reorder():
    return reversed_siblings
