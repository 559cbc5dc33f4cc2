"""Multiplicity correction for a family of comparisons between methods: the one implementation that the GLSO
campaign's statistics and the report's tests share (here, below both, because report/ must not reach the
simulator through glso/)."""

from __future__ import annotations


def holm(p: dict[str, float]) -> dict[str, float]:
    """Holm-Bonferroni adjusted p-values (step-down, monotone, capped at 1)."""
    order = sorted(p, key=p.get)
    adjusted, running = {}, 0.0
    for i, name in enumerate(order):
        running = max(running, min(1.0, (len(order) - i) * p[name]))
        adjusted[name] = running
    return adjusted
