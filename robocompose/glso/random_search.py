"""Random search with the grammar (thesis Fig. 8.1's "Random"): every step a fresh uniformly random
derivation that passes the dataset's filters (depth limit 40, >= 11 links, no self-penetration, valid rest
contacts). Redraws cost no evaluation, as in RoboGrammar's RandomSearch."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocompose.glso.designs import Proposal, random_grammar_design
from robocompose.grammar.derivation import MAX_DEPTH


@dataclass(frozen=True)
class RandomConfig:
    max_depth: int = MAX_DEPTH  # rule-sequence length limit of a derivation


class RandomSearch:
    def __init__(self, config: RandomConfig, seed: int, budget: int) -> None:
        self.config = config
        self.rng = np.random.default_rng([seed, 0x52414E44])  # "RAND": a stream of its own per run seed

    def propose(self, env) -> Proposal:
        return random_grammar_design(self.rng, self.config.max_depth)

    def tell(self, proposal: Proposal, score: float) -> None:
        pass  # random search does not learn
