from robocompose.glso.designs import random_grammar_design, run_stream, self_colliding
from robocompose.grammar.derivation import derive
from robocompose.grammar.tree import DesignTree
from tests.conftest import FLAT_REFERENCE


def test_self_collision_is_pybullets_verdict_at_rest():
    assert not self_colliding(derive(tuple(int(r) for r in FLAT_REFERENCE.split(","))).tree)
    stacked = DesignTree((-1, 0, 0), (14 + 0, 14 * 2 + 4, 14 * 2 + 4))  # two identical limbs on one mount point
    assert self_colliding(stacked)


def test_random_grammar_designs_continue_the_stream_where_they_stopped():
    first, k = random_grammar_design(run_stream(0, "random"), 0)
    second, k2 = random_grammar_design(run_stream(0, "random"), k)
    assert k2 > k >= 1 and first.tree != second.tree
    assert random_grammar_design(run_stream(0, "random"), 0)[0].tree == first.tree
