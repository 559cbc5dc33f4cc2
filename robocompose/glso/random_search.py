"""Random search with the grammar (thesis Fig. 8.1's "Random"): every step the next design of the dataset's
own enumeration (uniformly random derivations with its filters: depth limit 40, >= 11 links, no
self-penetration, valid rest contacts) on a random stream of the run's own. Rejected candidates cost no
evaluation, as in RoboGrammar's RandomSearch."""

from __future__ import annotations

from dataclasses import dataclass

from robocompose.glso.designs import random_grammar_design, run_stream
from robocompose.glso.method import Proposal, SearchEnv
from robocompose.grammar.derivation import MAX_DEPTH


@dataclass(frozen=True)
class RandomConfig:
    max_depth: int = MAX_DEPTH  # rule-sequence length limit of a derivation


class RandomSearch:
    def __init__(self, config: RandomConfig, seed: int, budget: int, env: SearchEnv) -> None:
        self.config = config
        self.stream = run_stream(seed, "random")  # not the dataset's stream: fresh designs
        self.k = 0  # next candidate of the stream

    def propose(self, env: SearchEnv) -> Proposal:
        proposal, self.k = random_grammar_design(self.stream, self.k, self.config.max_depth)
        return proposal

    def tell(self, proposal: Proposal, score: float) -> None:
        pass  # random search does not learn
