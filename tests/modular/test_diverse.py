"""The diverse query: candidates pairwise at the stated Hamming distance, taken in probability order; 1 is the plain
query; a bad distance is refused naming its field (params, the query, the CLI flag)."""

from __future__ import annotations

import itertools
import json

import pytest
import torch

from robocompose.cli import main
from robocompose.eggan.networks import Generator, NetworkConfig
from robocompose.eggan.query import generate, rank_distinct, save_generator, top_distinct
from robocompose.io.errors import InputError
from robocompose.modular.diverse import check_min_hamming, diverse_answer, diverse_distinct, spread
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.modular.plugins.eggan_problem import FitnessConfig, ModularEgganProblem
from robocompose.params import build_config

PARAMS = ModularParams(EvalSettings(), FitnessRule(), ExperimentsConfig())


def _hamming(a: str, b: str) -> int:
    return sum(x != y for x, y in zip(a, b, strict=True))


@pytest.fixture(scope="module")
def setup():
    torch.manual_seed(0)
    problem = ModularEgganProblem(PARAMS, FitnessConfig())
    generator = Generator(problem.task_shape, problem.design_shape, NetworkConfig(latent=8, hidden=16)).eval()
    return problem, generator


def test_spread_skips_a_design_within_the_distance_of_one_taken_in_order():
    ranked = ["wwwwww", "wwwwwl", "wwwwll", "llllll", "wwwlll", "lllllw"]
    assert spread(ranked, 10, 1) == ranked  # distinct designs: all
    # wwwwwl is 1 from wwwwww; wwwwll 2 from it; llllll 4 and 6 away; wwwlll 1 from wwwwll; lllllw 1 from llllll
    assert spread(ranked, 10, 2) == ["wwwwww", "wwwwll", "llllll"]
    assert spread(ranked, 2, 2) == ["wwwwww", "wwwwll"]
    assert spread(ranked, 10, 6) == ["wwwwww", "llllll"]


@pytest.mark.parametrize("min_hamming", [2, 3])
def test_the_diverse_query_is_pairwise_at_the_distance_in_probability_order(setup, min_hamming):
    problem, generator = setup
    picked = diverse_distinct(generator, problem, 1000, 10, 64, min_hamming, seed=3)
    designs = [r.design for r in picked]
    assert len(designs) == 10
    assert all(_hamming(a, b) >= min_hamming for a, b in itertools.combinations(designs, 2))
    scores = [r.score for r in picked]
    assert scores == sorted(scores, reverse=True)  # taken in probability order
    # exactly the greedy walk down the ranking of the first draws (64 draws hold 10 far enough apart here)
    sampled, output = generate(generator, problem, 1000, 64, 3)
    order = [r.design for r in rank_distinct(problem, sampled, output, len(sampled.designs))]
    assert designs == spread(order, 10, min_hamming) and designs[0] == order[0]
    skipped = set(order[:order.index(designs[-1])]) - set(designs)
    assert skipped and all(any(_hamming(s, d) < min_hamming for d in designs) for s in skipped)
    plain = [r.design for r in top_distinct(generator, problem, 1000, 10, 64, 3)]
    assert plain == order[:10] != designs  # the plain query keeps near-copies the diverse one skips


def test_min_hamming_1_is_the_plain_query_and_too_few_far_apart_answers_fewer(setup):
    problem, generator = setup
    assert [r.design for r in diverse_distinct(generator, problem, 1000, 10, 64, 1, seed=2)] == \
        [r.design for r in top_distinct(generator, problem, 1000, 10, 64, 2)]
    # at distance 6 no two designs share a port's module: at most 4 (one per module letter) can ever be taken
    far = diverse_distinct(generator, problem, 1000, 10, 64, 6, seed=2)
    assert 1 <= len(far) <= 4 and all(_hamming(a.design, b.design) == 6 for a, b in itertools.combinations(far, 2))
    assert diverse_answer(generator, 64, 2)(problem, 1000, 2, 5) == \
        [r.design for r in diverse_distinct(generator, problem, 1000, 5, 64, 2, seed=2)]


@pytest.mark.parametrize("value", [0, 7, -1, True, 2.0, "2"])
def test_a_bad_distance_is_refused_naming_the_field(setup, value):
    problem, generator = setup
    with pytest.raises(InputError, match=r"^min_hamming: expected an integer from 1 \(distinct designs\) to 6"):
        check_min_hamming(value, "min_hamming")
    with pytest.raises(InputError, match=r"^min_hamming: expected an integer"):
        diverse_distinct(generator, problem, 1000, 3, 8, value)
    with pytest.raises(InputError, match=r"^eggan_modular\.protocol\.diverse_hamming: expected "):
        build_config(EgganModularParams, {"protocol": {"diverse_hamming": value}}, "eggan_modular")
    assert build_config(EgganModularParams, {}, "eggan_modular").protocol.diverse_hamming == 2


def test_compose_min_hamming_answers_far_apart_designs_and_refuses_a_bad_value(tmp_path, setup, capsys):
    problem, generator = setup
    model = save_generator(generator, problem, tmp_path / "g.pt", {"run_key": "test"})
    params = tmp_path / "params.yaml"
    params.write_text("modular:\n  eval: {control_steps: 3, settle_steps: 10, terrain: {}}\n  fitness: {}\n"
                      "  experiments: {}\ncompute: {workers: 1, cache: \"\"}\n")
    assert main(["compose", "modular", "--terrain-seed", "1000", "--k", "5", "--min-hamming", "2", "--model",
                 str(model), "--params", str(params)]) == 0
    out = json.loads(capsys.readouterr().out)
    designs = [d["design"] for d in out["designs"]]
    assert out["min_hamming"] == 2 and out["found"] == len(designs) == 5
    assert all(_hamming(a, b) >= 2 for a, b in itertools.combinations(designs, 2))
    assert not any(PARAMS.fitness.skips(d) for d in designs)
    assert main(["compose", "modular", "--terrain-seed", "1000", "--min-hamming", "0", "--model", str(model),
                 "--params", str(params)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--min-hamming: expected an integer from 1 (distinct designs) to 6" in err
