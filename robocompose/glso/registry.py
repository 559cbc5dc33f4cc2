"""The GLSO search methods by name: a new method is its own file (a `method.SearchMethod` and the dataclass of
its settings) plus one line here. Its settings are read from `glso.<section>` of params.yaml (methods may share
a section, as the three latent ablations share `bo`), its name is what `glso.methods` and `--method` take.
`METHODS` is the only list of them: titles, figure groups (`robocompose.glso.GROUPS`) and legend order live on
the entries, and the stages write them into their artifacts (`describe`) for the report, which imports no torch.

Importing this module imports every method (torch, bayes_opt, botorch): the command line's parser does not.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from robocompose.evaluation.evaluate import INVALID_SCORE, ROBOGRAMMAR_INVALID_SCORE
from robocompose.glso import GROUPS, REFERENCE
from robocompose.glso.bo import BOConfig, LatentBO, NoReductionConfig, ReaskConfig, WideFloorConfig
from robocompose.glso.ghs import GHSConfig, GraphHeuristicSearch
from robocompose.glso.graph_ga import GAConfig, GraphGA
from robocompose.glso.mcts import MCTSConfig, TreeSearch
from robocompose.glso.method import SearchMethod
from robocompose.glso.random_search import RandomConfig, RandomSearch
from robocompose.glso.turbo import TrustRegionBO, TurboConfig


@dataclass(frozen=True)
class Method:
    """A registered search method: its class, its settings' dataclass and params section, its title (the
    thesis's legend name) and figure groups (keys of `robocompose.glso.GROUPS`), the VAE it searches (`variant`
    fills the {variant} of `glso.models`; None for a method without a VAE), the score it is told for a
    design that cannot be simulated, by status (its original's), whether each of its calls draws a
    controller seed of its own (`runs.call_seeds`; else every call uses `evaluation.seed`), whether its VAE is
    the thesis-scale one (`glso.thesis_models`, latent/thesis_scale.py; a campaign searches it only once its gate
    has passed) and, for an arm of GLSO, the methods that ablate it as GLSO_nopred and GLSO_nogram ablate GLSO
    (the arm's own Fig. 8.2 family)."""

    cls: type[SearchMethod]
    settings: type
    section: str
    title: str
    groups: tuple[str, ...]
    variant: str | None = None
    invalid_score: dict[str, float] = field(default_factory=lambda: dict(ROBOGRAMMAR_INVALID_SCORE))
    fresh_seeds: bool = False  # the original GLSO's protocol: every call simulated at a controller seed of its own
    thesis_vae: bool = False  # searches the VAE at the thesis's scale, not the default profile's
    ablations: tuple[str, ...] = ()  # registered methods that ablate this arm (its Fig. 8.2 family)

    def __post_init__(self) -> None:
        unknown = [group for group in self.groups if group not in GROUPS]
        if unknown:  # a misspelt group would leave the method out of its figure and its claim
            raise TypeError(f"glso method {self.title}: figure groups {unknown} are not of {list(GROUPS)}")

    def model_path(self, models: str) -> Path | None:
        return None if self.variant is None else Path(models.format(variant=self.variant))


# In the order of the legends of Figs. 8.1 and 8.2 and of the report's tables. Invalid scores: GLSO's run_bo.py
# (3.8 / 4.0); MCTS, GHS and random search RoboGrammar's -2.0 (heuristic_search_algo_mpc.py; design_search.py
# redraws such a design instead, which would hide the call it cost); the GA, whose NGE original has no such
# design, the same.
METHODS: dict[str, Method] = {
    "glso": Method(LatentBO, BOConfig, "bo", "GLSO", ("baselines", "ablations"), variant="full",
                   invalid_score=INVALID_SCORE),
    "glso_nopred": Method(LatentBO, BOConfig, "bo", "GLSO_nopred", ("ablations",), variant="nopred",
                          invalid_score=INVALID_SCORE),
    "glso_nogram": Method(LatentBO, BOConfig, "bo", "GLSO_nogram", ("ablations",), variant="nogram",
                          invalid_score=INVALID_SCORE),
    "random": Method(RandomSearch, RandomConfig, "random", "Random", ("baselines",)),
    "ga": Method(GraphGA, GAConfig, "ga", "GA", ("baselines",)),
    "mcts": Method(TreeSearch, MCTSConfig, "mcts", "MCTS", ("baselines",)),
    "ghs": Method(GraphHeuristicSearch, GHSConfig, "ghs", "GHS", ("baselines",)),
    # GLSO variants that keep the search from collapsing onto its incumbent (issue 42; in no thesis figure: the
    # pilot, `robocompose glso-campaign pilot`, picks one for the campaign)
    "glso_nodr": Method(LatentBO, NoReductionConfig, "bo_nodr", "GLSO, no domain reduction", (), variant="full",
                        invalid_score=INVALID_SCORE),
    "glso_floor": Method(LatentBO, WideFloorConfig, "bo_floor", "GLSO, window floor 2", (), variant="full",
                         invalid_score=INVALID_SCORE),
    "glso_reask": Method(LatentBO, ReaskConfig, "bo_reask", "GLSO, repeats re-asked", (), variant="full",
                         invalid_score=INVALID_SCORE),
    # GLSO's VAE searched by a trust-region BO instead (issue 42, item 3: TuRBO-1 with BoTorch, turbo.py): its region
    # halves around the incumbent after failures and restarts elsewhere once it has collapsed
    "glso_turbo": Method(TrustRegionBO, TurboConfig, "bo_turbo", "GLSO, trust region (TuRBO)", (), variant="full",
                         invalid_score=INVALID_SCORE),
    # GLSO under its original's protocol (issue 42, item 2): a fresh controller seed per call, so a repeat is
    # simulated again and its best so far is a maximum over noisy re-draws; held-out scoring measures the inflation
    "glso_thesis": Method(LatentBO, BOConfig, "bo", "GLSO, thesis protocol", (), variant="full",
                          invalid_score=INVALID_SCORE, fresh_seeds=True),
    # The improved GLSO (the pilot's winner, TuRBO) on the thesis-scale VAE and its predictor ablation searched the
    # same way (issue 42, item 6): what GLSO and GLSO_nopred do once the VAE is the thesis's size
    "glso_turbo_thesis": Method(TrustRegionBO, TurboConfig, "bo_turbo", "GLSO, trust region (TuRBO), thesis-scale VAE",
                                (), variant="full", invalid_score=INVALID_SCORE, thesis_vae=True,
                                ablations=("glso_nopred_turbo_thesis",)),
    "glso_nopred_turbo_thesis": Method(TrustRegionBO, TurboConfig, "bo_turbo",
                                       "GLSO_nopred, trust region (TuRBO), thesis-scale VAE", (), variant="nopred",
                                       invalid_score=INVALID_SCORE, thesis_vae=True),
}


def family(group: str, reference: str = REFERENCE) -> tuple[str, ...]:
    """The methods `reference` (GLSO or one of its arms) is compared with in figure group `group`, in registry
    order: the group's members but GLSO; an arm's ablations are its own (`Method.ablations`)."""
    if group == "ablations" and reference != REFERENCE:
        return METHODS[reference].ablations
    return tuple(name for name, method in METHODS.items() if group in method.groups and name != REFERENCE)


def describe() -> list[dict]:
    """Every registered method's name, title, figure groups, VAE variant (None without one) and scale, protocol
    (`fresh_seeds`) and the methods it is compared with per figure group (`family`), in registry order: what the
    stages write into their artifacts so that the report (no torch, so no registry) can name and group the
    methods, title each VAE by the method that searches it and name the protocol and the family of each verdict."""
    return [{"name": name, "title": method.title, "groups": list(method.groups), "variant": method.variant,
             "fresh_seeds": method.fresh_seeds, "thesis_vae": method.thesis_vae,
             "families": {group: list(family(group, name)) for group in GROUPS}}
            for name, method in METHODS.items()]


def settings_sections() -> dict[str, type]:
    """Params section -> settings dataclass, over every registered method (each section once)."""
    sections: dict[str, type] = {}
    for name, method in METHODS.items():
        if sections.setdefault(method.section, method.settings) is not method.settings:
            raise TypeError(f"glso method {name}: section {method.section!r} already holds "
                            f"{sections[method.section].__name__}, not {method.settings.__name__}")
    return sections
