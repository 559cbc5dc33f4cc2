"""Real-time queries: ranked distinct designs with mixture probabilities; generator files round-trip."""

import pytest
import torch

from robocompose.eggan.networks import Generator, NetworkConfig
from robocompose.eggan.query import (
    generate,
    generator_info,
    load_generator,
    model_code_digest,
    rank_distinct,
    save_generator,
    top_distinct,
)
from robocompose.io.errors import InputError


def test_ranking_is_distinct_sorted_and_probabilities(match_problem):
    generator = Generator(match_problem.task_shape, match_problem.design_shape, NetworkConfig(latent=8, hidden=16))
    sampled, output = generate(generator, match_problem, (0, 1, 2, 3, 0, 1), 64, seed=0)
    ranked = rank_distinct(match_problem, sampled, output, 10)
    ids = [match_problem.design_id(r.design) for r in ranked]
    assert len(ids) == len(set(ids)) == 10
    scores = [r.score for r in ranked]
    assert scores == sorted(scores, reverse=True) and 0 < sum(scores) <= 1
    again, _ = generate(generator, match_problem, (0, 1, 2, 3, 0, 1), 64, seed=0)
    assert again.designs == sampled.designs  # a query is a function of its seed


def test_a_sharp_generator_still_answers_k_distinct_designs_by_drawing_more(match_problem):
    """A generator that almost always draws one design: 8 draws hold fewer than 5 distinct designs, so the
    query doubles its draws until it finds 5; a filter that nothing passes answers nothing."""
    torch.manual_seed(0)
    generator = Generator(match_problem.task_shape, match_problem.design_shape, NetworkConfig(latent=8, hidden=16))
    with torch.no_grad():
        generator.body[-1].bias.view(match_problem.design_shape)[:, 0] += 4.0  # every row picks choice 0 ~95%
    task = (0, 1, 2, 3, 0, 1)
    assert len({match_problem.design_id(d) for d in generate(generator, match_problem, task, 8)[0].designs}) < 5
    ranked = top_distinct(generator, match_problem, task, 5, 8)
    assert len({match_problem.design_id(r.design) for r in ranked}) == 5
    assert [r.score for r in ranked] == sorted((r.score for r in ranked), reverse=True)
    assert top_distinct(generator, match_problem, task, 5, 8, keep=lambda design: False) == []
    kept = top_distinct(generator, match_problem, task, 3, 8, keep=lambda design: design[0] != 0)
    assert len(kept) == 3 and all(r.design[0] != 0 for r in kept)


@pytest.mark.parametrize("half", [False, True])
def test_generator_file_round_trip(tmp_path, match_problem, half):
    generator = Generator(match_problem.task_shape, match_problem.design_shape, NetworkConfig(latent=8, hidden=16))
    generator.eval()
    path = save_generator(generator, match_problem, tmp_path / "g.pt", {"note": 1}, half=half)
    loaded, info = load_generator(path, match_problem)
    task = match_problem.encode_task((0,) * 6).unsqueeze(0)
    z = torch.randn(4, 8)
    a, b = generator(z, generator.encode(task).expand(4, -1)), loaded(z, loaded.encode(task).expand(4, -1))
    assert torch.allclose(a, b, atol=1e-2 if half else 0) and info["note"] == 1
    assert info["weights"] == ("float16" if half else "float32")


def test_generator_info_reads_the_files_info_and_names_a_file_of_another_kind(tmp_path, match_problem):
    from robocompose.io.torch_file import save_torch

    generator = Generator(match_problem.task_shape, match_problem.design_shape, NetworkConfig(latent=8, hidden=16))
    path = save_generator(generator, match_problem, tmp_path / "g.pt", {"note": 1})
    info = generator_info(path)
    assert info == load_generator(path, match_problem)[1]
    assert info["problem"] == "match" and info["design_shape"] == [6, 4] and info["note"] == 1
    save_torch({"weights": 1}, tmp_path / "other.pt")
    with pytest.raises(InputError, match="other.pt: not an EG-GAN generator file"):
        generator_info(tmp_path / "other.pt")


def test_the_model_code_follows_the_networks_not_the_storage(monkeypatch):
    """A change to how results are stored (robocompose/io) keeps every trained generator loadable; a change
    to the networks does not."""
    from robocompose.io import provenance

    before = model_code_digest()
    real = provenance.definitions

    def edited(module: str):
        def definitions(path):
            table, aliases = real(path)
            if path.parent.name == module:
                table = {**table, "ADDED_CONSTANT": (provenance._Definition("edited", frozenset()),)}
            return table, aliases
        return definitions

    try:
        for module, moves in (("io", False), ("eggan", True)):
            monkeypatch.setattr(provenance, "definitions", edited(module))
            provenance.code_digest.cache_clear()
            assert (model_code_digest() != before) is moves, module
    finally:  # no digest computed under the edit may outlive the test
        provenance.code_digest.cache_clear()
