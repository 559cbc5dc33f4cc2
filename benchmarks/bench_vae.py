"""Benchmark: graph VAE training steps at thesis size (hidden 450, latent 28, batch 32), 2 threads.

vae.steps_per_s: training steps per second (batching, forward, backward, Adam), level-wise sweeps.
vae.reference_steps_per_s: the same model and batches computed the original's way (20 synchronous
    message-passing iterations over all edges in the encoder, one depth-first step at a time in the
    decoder), in the same run.
vae.speedup_vs_reference: their ratio (target >= 3).
vae.flop_utilization: matmul FLOPs of one step (torch's FlopCounterMode, forward + backward) x steps/s
    / the fp32 matmul FLOP/s measured in the same run (target >= 0.25).
vae.matmul_gflops: that dense matmul rate (1024 x 1024 x 1024, same threads).
vae.paper_hours: hours the paper profile's 400k steps take at vae.steps_per_s.
Trees: random grammar derivations with >= 11 links (the reference's dataset filter).
"""

from __future__ import annotations

import time

import numpy as np
import torch
from torch.utils.flop_counter import FlopCounterMode

from robocompose.grammar.derivation import random_derivation
from robocompose.latent.batch import collate
from robocompose.latent.constraints import replay
from robocompose.latent.model import GraphVAE, VAEConfig, level_sweeps
from robocompose.latent.reference import original

THREADS, BATCH, MIN_LINKS, PAPER_STEPS = 2, 32, 11, 400_000


def _replays(n: int, seed: int = 0) -> list:
    rng, out = np.random.default_rng(seed), []
    while len(out) < n:
        d = random_derivation(rng)
        if d is not None and d.tree.n_links >= MIN_LINKS:
            out.append(replay(d.tree, "grammar", 50))
    return out


def _step(model, optimizer, replays, propagate) -> None:
    batch = collate(replays, np.zeros((len(replays), 16)))
    out = model(batch, 0.1, 20.0, torch.randn(len(replays), model.config.latent), propagate=propagate)
    optimizer.zero_grad()
    out["loss"].backward()
    optimizer.step()


def _rate(model, optimizer, batches, propagate, min_seconds: float) -> float:
    for replays in batches:  # warm-up: first touches of each batch's buffers
        _step(model, optimizer, replays, propagate)
    steps, started = 0, time.perf_counter()
    while steps < 2 or time.perf_counter() - started < min_seconds:
        _step(model, optimizer, batches[steps % len(batches)], propagate)
        steps += 1
    return steps / (time.perf_counter() - started)


def _matmul_flops(n: int = 1024, min_seconds: float = 3.0) -> float:
    a, b = torch.randn(n, n), torch.randn(n, n)
    a @ b
    reps, started = 0, time.perf_counter()
    while time.perf_counter() - started < min_seconds:
        a @ b
        reps += 1
    return 2 * n**3 * reps / (time.perf_counter() - started)


def run() -> dict[str, float]:
    torch.set_num_threads(THREADS)
    torch.manual_seed(0)
    replays = _replays(4 * BATCH)
    batches = [replays[i: i + BATCH] for i in range(0, len(replays), BATCH)]
    model = GraphVAE(VAEConfig())
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-4)
    with FlopCounterMode(display=False) as counter:  # the mean over the batches the timing cycles through
        for replays_of_batch in batches:
            batch = collate(replays_of_batch, np.zeros((BATCH, 16)))
            model(batch, 0.1, 20.0, torch.randn(BATCH, 28))["loss"].backward()
    flops_per_step = counter.get_total_flops() / len(batches)
    peak = _matmul_flops()
    ours = _rate(model, optimizer, batches, level_sweeps, min_seconds=20.0)
    reference = _rate(model, optimizer, batches, original(), min_seconds=20.0)
    return {"vae.steps_per_s": ours, "vae.reference_steps_per_s": reference,
            "vae.speedup_vs_reference": ours / reference, "vae.flop_utilization": flops_per_step * ours / peak,
            "vae.matmul_gflops": peak / 1e9, "vae.gflop_per_step": flops_per_step / 1e9,
            "vae.paper_hours": PAPER_STEPS / ours / 3600}
