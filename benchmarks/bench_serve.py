"""Benchmark: the composition service under load, beside the command line's wall time for the same query.

A real `robocompose serve --workers 2` (two query processes; shipped generators) on loopback; CLIENTS
closed-loop clients (each sends its next request when the last is answered, keep-alive connections) in this process;
latency is the client's wait, send to last byte. Figures (milliseconds, over REQUESTS requests after WARMUP):
serve.modular_p50_ms / _p99_ms: `POST /compose/modular` by terrain seed, seeds cycling through SEED_POOL terrains
    (the service keeps the height maps of recent terrains; measured after WARMUP_POOL queries, so warm).
serve.modular_new_terrain_p50_ms: every request a terrain seed never asked before (blocks generated per query).
serve.modular_heightmap_p50_ms: a 50 x 20 height map as JSON.
serve.teams_p50_ms / _p99_ms: `POST /compose/teams` without measured costs (decomposition, generator, the distinct
    allocations), CHIPS synthetic chips cycled.
serve.teams_measured_p50_ms / _p99_ms: the same with `measure=true`: the front measured by the ergodic optimiser.
cli.compose_modular_wall_ms, cli.compose_teams_wall_ms: `robocompose compose modular --terrain-seed S` and
    `robocompose compose teams --chip X --budget 30` as a user runs them (new process, imports, model load), median
    of CLI_RUNS. serve.modular_speedup_vs_cli / serve.teams_measured_speedup_vs_cli: their ratios to the p50s.
Goals (issue 47): modular p50 <= 20 ms, teams p50 <= 150 ms, on 2 cores with 8 clients.
"""

from __future__ import annotations

import http.client
import json
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from robocompose.teams.chips import label_png_bytes, synthetic_chip

CLIENTS = 8
WORKERS = 2  # query processes: one per core
REQUESTS = 500
WARMUP = 16  # requests before the measured ones, per endpoint
SEED_POOL = 64
WARMUP_POOL = 4 * SEED_POOL  # a warm service: every query process has met the pool's seeds before measuring
CHIPS = 16
CLI_RUNS = 3


def start_server() -> tuple[subprocess.Popen, str]:
    """`robocompose serve --workers WORKERS` on a free port; it prints its address once every query process is up."""
    process = subprocess.Popen([sys.executable, "-m", "robocompose.cli", "serve", "--port", "0", "--workers",
                                str(WORKERS)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    return process, json.loads(process.stdout.readline())["serving"].removeprefix("http://").rstrip("/")


def load(address: str, requests: list[tuple[str, bytes, str]], warmup: int = WARMUP) -> np.ndarray:
    """Latencies (ms) of `requests` after the first `warmup`, sent by CLIENTS closed-loop clients; every answer must
    be 200."""
    local = threading.local()

    def send(request: tuple[str, bytes, str]) -> float:
        if not hasattr(local, "connection"):
            local.connection = http.client.HTTPConnection(address, timeout=600)
        path, body, kind = request
        started = time.perf_counter()
        try:
            local.connection.request("POST", path, body, {"Content-Type": kind})
            response = local.connection.getresponse()
        except (BrokenPipeError, ConnectionResetError, http.client.RemoteDisconnected):
            # the server closed a connection idle for over its keep-alive time (5 s, uvicorn's): a client reconnects
            local.connection.close()
            local.connection.request("POST", path, body, {"Content-Type": kind})
            response = local.connection.getresponse()
        data = response.read()
        waited = 1000 * (time.perf_counter() - started)
        if response.status != 200:
            raise RuntimeError(f"{path}: {response.status} {data[:200]!r}")
        return waited

    with ThreadPoolExecutor(CLIENTS) as pool:
        list(pool.map(send, requests[:warmup]))
        return np.array(list(pool.map(send, requests[warmup:])))


def cli_wall_ms(argv: list[str]) -> float:
    times = []
    for _ in range(CLI_RUNS):
        started = time.perf_counter()
        subprocess.run([sys.executable, "-m", "robocompose.cli", *argv], check=True, capture_output=True)
        times.append(1000 * (time.perf_counter() - started))
    return float(np.median(times))


def run() -> dict[str, float]:
    n = WARMUP + REQUESTS
    modular = "application/json"
    pooled = [("/compose/modular", json.dumps({"terrain_seed": 1000 + i % SEED_POOL}).encode(), modular)
              for i in range(n - WARMUP + WARMUP_POOL)]
    new = [("/compose/modular", json.dumps({"terrain_seed": 500_000 + i}).encode(), modular) for i in range(n)]
    maps = np.random.default_rng(0).uniform(0, 0.2, (8, 50, 20)).round(3)
    heightmaps = [("/compose/modular", json.dumps({"heightmap": maps[i % 8].tolist()}).encode(), modular)
                  for i in range(n)]
    chips = [label_png_bytes(synthetic_chip(100 + i).classes) for i in range(CHIPS)]
    teams = [(f"/compose/teams?name=chip{i % CHIPS}", chips[i % CHIPS], "image/png") for i in range(n)]
    measured = [(f"/compose/teams?name=chip{i % CHIPS}&measure=true", chips[i % CHIPS], "image/png")
                for i in range(n)]
    process, address = start_server()
    try:
        latencies = {"modular": load(address, pooled, WARMUP_POOL)}
        latencies.update({name: load(address, requests) for name, requests in (
            ("modular_new_terrain", new), ("modular_heightmap", heightmaps), ("teams", teams),
            ("teams_measured", measured))})
    finally:
        process.terminate()
        process.wait(timeout=60)
    with tempfile.TemporaryDirectory() as folder:
        chip = Path(folder) / "chip100.png"
        chip.write_bytes(chips[0])
        modular_cli = cli_wall_ms(["compose", "modular", "--terrain-seed", "1000"])
        teams_cli = cli_wall_ms(["compose", "teams", "--chip", str(chip), "--budget", "30"])
    figures = {}
    for name, values in latencies.items():
        figures[f"serve.{name}_p50_ms"] = float(np.percentile(values, 50))
        figures[f"serve.{name}_p99_ms"] = float(np.percentile(values, 99))
    return {**figures, "serve.requests_per_endpoint": float(REQUESTS), "serve.clients": float(CLIENTS),
            "serve.workers": float(WORKERS),
            "cli.compose_modular_wall_ms": modular_cli, "cli.compose_teams_wall_ms": teams_cli,
            "serve.modular_speedup_vs_cli": modular_cli / figures["serve.modular_p50_ms"],
            "serve.teams_measured_speedup_vs_cli": teams_cli / figures["serve.teams_measured_p50_ms"]}


if __name__ == "__main__":
    print(run())
