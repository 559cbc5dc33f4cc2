from robocompose.glso.designs import rejection
from robocompose.grammar.derivation import derive
from robocompose.grammar.tree import DesignTree
from tests.conftest import FLAT_REFERENCE


def test_rejection_names_why_a_design_may_not_be_proposed():
    assert rejection(derive(tuple(int(r) for r in FLAT_REFERENCE.split(","))).tree, dataset_filters=True) == ""
    small = DesignTree((-1, 0), (14 + 0, 14 + 1))  # a body root and one fixed body link
    assert rejection(small, dataset_filters=True) == "too_few_links"
    assert rejection(small, dataset_filters=False) in ("", "self_collision")
