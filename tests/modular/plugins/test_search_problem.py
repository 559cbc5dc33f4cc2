import numpy as np

from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.plugins.search_problem import ModularProblem, hamming


def problem(**kw):
    return ModularProblem(3, EvalSettings(control_steps=4), FitnessRule(), **kw)


def test_operators_stay_in_the_design_space():
    p, rng = problem(), np.random.default_rng(0)
    designs = p.sample(rng, 50)
    assert all(len(d) == 6 and set(d) <= set("nlwb") for d in designs)
    assert len(set(designs)) > 40
    assert p.mutate("llllll", rng, 0.0) == "llllll"
    assert hamming(p.mutate("llllll", rng, 1.0), "llllll") >= 3  # every port redrawn (1/4 keep their letter)
    a, b = p.crossover("llllll", "wwwwww", rng)
    assert all({x, y} == {"l", "w"} for x, y in zip(a, b, strict=True))  # complementary uniform crossover
    assert p.distance("lwbnlw", "lwbnll") == 1.0


def test_evaluate_applies_the_rule_and_counts_sim_steps():
    p = problem()
    fitness = p.evaluate(["nnnnnn", "wwwwww", "wwwwww"])
    assert fitness[0] == -10.0 and fitness[1] == fitness[2] and fitness[1] > 0
    settings = EvalSettings(control_steps=4)
    assert p.sim_steps == 2 * (settings.settle_steps + 4 * settings.sim_steps_per_control)
