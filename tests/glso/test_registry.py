import dataclasses
import inspect

import pytest

from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.glso.bo import BOConfig, NoReductionConfig, ReaskConfig, WideFloorConfig
from robocompose.glso.designs import random_grammar_design, run_stream
from robocompose.glso.method import Proposal, SearchEnv
from robocompose.glso.random_search import RandomConfig, RandomSearch
from robocompose.glso.registry import METHODS, Method, describe, family, settings_sections
from robocompose.glso.runs import GLSOConfig, RunSpec, run_search
from robocompose.glso.turbo import TurboConfig
from robocompose.io.errors import InputError
from robocompose.params import build_config
from tests.glso.conftest import fake_objective


def test_the_registry_holds_the_thesis_methods_and_the_latent_ones_name_their_vae():
    assert list(METHODS) == ["glso", "glso_nopred", "glso_nogram", "random", "ga", "mcts", "ghs", "glso_nodr",
                             "glso_floor", "glso_reask", "glso_turbo", "glso_thesis", "glso_turbo_thesis",
                             "glso_nopred_turbo_thesis"]
    assert {name: m.variant for name, m in METHODS.items() if m.variant} == {
        "glso": "full", "glso_nopred": "nopred", "glso_nogram": "nogram", "glso_nodr": "full", "glso_floor": "full",
        "glso_reask": "full", "glso_turbo": "full", "glso_thesis": "full", "glso_turbo_thesis": "full",
        "glso_nopred_turbo_thesis": "nopred"}
    # an arm's ablations are registered methods searched the way it searches, on a VAE of the same scale
    for name, method in METHODS.items():
        for ablation in method.ablations:
            assert (METHODS[ablation].cls, METHODS[ablation].thesis_vae) == (method.cls, method.thesis_vae), name
    for name, method in METHODS.items():  # SearchMethod's constructor, propose and tell
        assert callable(method.cls.propose) and callable(method.cls.tell), name
        assert list(inspect.signature(method.cls).parameters) == ["config", "seed", "budget", "env"], name
        assert dataclasses.is_dataclass(method.settings), name
    assert [(m["title"], m["groups"]) for m in describe()] == [
        ("GLSO", ["baselines", "ablations"]), ("GLSO_nopred", ["ablations"]), ("GLSO_nogram", ["ablations"]),
        ("Random", ["baselines"]), ("GA", ["baselines"]), ("MCTS", ["baselines"]), ("GHS", ["baselines"]),
        ("GLSO, no domain reduction", []), ("GLSO, window floor 2", []), ("GLSO, repeats re-asked", []),
        ("GLSO, trust region (TuRBO)", []), ("GLSO, thesis protocol", []),
        ("GLSO, trust region (TuRBO), thesis-scale VAE", []),
        ("GLSO_nopred, trust region (TuRBO), thesis-scale VAE", [])]
    assert family("baselines") == ("random", "ga", "mcts", "ghs") and family("ablations") == (
        "glso_nopred", "glso_nogram")  # the methods GLSO is compared with in Figs. 8.1 and 8.2
    assert family("baselines", "glso_turbo_thesis") == family("baselines")
    assert family("ablations", "glso_turbo_thesis") == ("glso_nopred_turbo_thesis",)
    assert family("ablations", "glso_thesis") == ()  # an arm without ablations of its own meets the baselines only
    record = {m["name"]: m["families"] for m in describe()}  # what the report reads the families from
    assert record["glso_turbo_thesis"] == {"baselines": ["random", "ga", "mcts", "ghs"],
                                           "ablations": ["glso_nopred_turbo_thesis"]}
    with pytest.raises(TypeError, match=r"figure groups \['baseline'\] are not of \['baselines', 'ablations'\]"):
        Method(RandomSearch, RandomConfig, "random", "Typo", ("baseline",))


def test_the_config_has_one_section_per_registered_settings_and_names_a_bad_field():
    assert settings_sections() == {"bo": BOConfig, **{s: METHODS[s].settings for s in ("random", "ga", "mcts", "ghs")},
                                   "bo_nodr": NoReductionConfig, "bo_floor": WideFloorConfig, "bo_reask": ReaskConfig,
                                   "bo_turbo": TurboConfig}
    config = GLSOConfig(bo={"init": 4})
    assert config.settings("glso_nogram") == BOConfig(init=4) and config.settings("random") == RandomConfig()
    # a variant's section defaults to what makes it the variant, whatever `bo` says
    assert (config.settings("glso_nodr").domain_reduction, config.settings("glso_floor").minimum_window,
            config.settings("glso_reask").reask) == (False, 2.0, 3)
    assert config.model_path("glso_nopred").name == "vae_nopred.pt" and config.model_path("mcts") is None
    assert str(config.model_path("glso_nopred_turbo_thesis")) == "measured/vae_thesis/vae_nopred.pt"
    with pytest.raises(InputError, match=r"glso\.bo\.nit: unknown field"):
        build_config(GLSOConfig, {"bo": {"nit": 4}}, "glso")
    with pytest.raises(InputError, match="methods: expected some of"):
        GLSOConfig(methods=["nelder_mead"])


def test_two_methods_may_share_a_section_only_with_one_settings_class(monkeypatch):
    monkeypatch.setitem(METHODS, "clash", Method(METHODS["random"].cls, BOConfig, "random", "Clash", ()))
    with pytest.raises(TypeError, match="section 'random' already holds RandomConfig"):
        settings_sections()


class FirstDesigns:
    """A toy method: the random designs of its stream, in order, learning nothing (what a new file would hold)."""

    def __init__(self, config: RandomConfig, seed: int, budget: int, env: SearchEnv) -> None:
        self.stream, self.k, self.told = run_stream(seed, "first"), 0, []

    def propose(self, env: SearchEnv) -> Proposal:
        proposal, self.k = random_grammar_design(self.stream, self.k, 40)
        return proposal

    def tell(self, proposal: Proposal, score: float) -> None:
        self.told.append(score)


def test_a_new_method_is_one_registry_line(monkeypatch, small_config, tmp_path):
    monkeypatch.setitem(METHODS, "first", Method(FirstDesigns, RandomConfig, "random", "First", ("baselines",)))
    config = dataclasses.replace(small_config, methods=["first"], budget=4)
    checkpoint = tmp_path / "run.ckpt"
    steps = run_search(RunSpec("flat", "first", 0), config, EvaluationConfig(), objective_fn=fake_objective,
                       checkpoint=checkpoint)
    assert list(steps["method"]) == ["first"] * 4 and steps["design_id"].nunique() == 4
    # its checkpoint resumes like any other method's: a finished run is read back, not run again
    again = run_search(RunSpec("flat", "first", 0), config, EvaluationConfig(),
                       objective_fn=lambda tree: pytest.fail("a finished run evaluated again"), checkpoint=checkpoint)
    assert again.equals(steps)
