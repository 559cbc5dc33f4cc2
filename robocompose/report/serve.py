"""The report's section on the composition service: latency under load beside the command line's wall time, from
`make bench` (reports/benchmarks.json, keys serve.* and cli.*; benchmarks/bench_serve.py says how they are measured)."""

from __future__ import annotations

from pathlib import Path

from robocompose.io import read_json

# (key stem, what is asked, target p50 in ms or None, the command line's key for the same question or None)
ENDPOINTS = (
    ("modular", "modular designs by terrain seed (64 recent terrains)", 20.0, "cli.compose_modular_wall_ms"),
    ("modular_new_terrain", "modular designs, a terrain seed never asked before", None, None),
    ("modular_heightmap", "modular designs for a 50 x 20 height map (JSON)", None, None),
    ("teams", "teams: decomposition and the generator's allocations, costs not measured", 150.0, None),
    ("teams_measured", "teams: the front measured by the ergodic optimiser, budget 30", None,
     "cli.compose_teams_wall_ms"),
)


def section(reports_dir: Path) -> str:
    lines = ["## The composition service", ""]
    path = Path(reports_dir) / "benchmarks.json"
    figures = read_json(path) if path.exists() else {}
    if "serve.modular_p50_ms" not in figures:
        return "\n".join(lines + ["Not benchmarked: `make bench` (benchmarks/bench_serve.py) measures it."])
    clients, requests = int(figures["serve.clients"]), int(figures["serve.requests_per_endpoint"])
    workers = int(figures.get("serve.workers", 0))
    lines += [f"`robocompose serve --workers {workers}` (query processes) with the shipped generators, "
              f"{requests} requests per endpoint from {clients} closed-loop clients on loopback, on the benchmark's "
              f"machine ({figures.get('machine', {}).get('cores', '?')} cores, shared by server and clients); "
              "latency is a client's wait, send to last byte. The command line answers the same question in a new "
              "process (imports and model load included).", "",
              "| query | p50 (ms) | p99 (ms) | target p50 | the command line (ms) |", "|---|---|---|---|---|"]
    for stem, what, target, cli in ENDPOINTS:
        p50, p99 = figures.get(f"serve.{stem}_p50_ms"), figures.get(f"serve.{stem}_p99_ms")
        if p50 is None:
            continue
        verdict = "" if target is None else f"<= {target:g} ({'met' if p50 <= target else 'not met'})"
        wall = "" if cli is None or cli not in figures else f"{figures[cli]:,.0f}"
        lines.append(f"| {what} | {p50:.1f} | {p99:.1f} | {verdict} | {wall} |")
    return "\n".join(lines)
