"""The report's service section: the latency figures of `make bench` against their targets, or why there are none."""

from __future__ import annotations

import json

from robocompose.report.serve import section


def test_without_a_benchmark_the_section_says_how_to_measure(tmp_path):
    assert "Not benchmarked: `make bench`" in section(tmp_path)


def test_each_endpoints_p50_is_judged_against_its_target_beside_the_command_line(tmp_path):
    (tmp_path / "benchmarks.json").write_text(json.dumps({
        "serve.clients": 8, "serve.requests_per_endpoint": 500, "serve.workers": 2, "machine": {"cores": 2},
        "serve.modular_p50_ms": 12.5, "serve.modular_p99_ms": 30.0, "cli.compose_modular_wall_ms": 2600.0,
        "serve.teams_p50_ms": 151.0, "serve.teams_p99_ms": 400.0}))
    text = section(tmp_path)
    assert "| modular designs by terrain seed (64 recent terrains) | 12.5 | 30.0 | <= 20 (met) | 2,600 |" in text
    assert "| teams: decomposition and the generator's allocations, costs not measured | 151.0 | 400.0 | <= 150 " \
           "(not met) |  |" in text
    assert "`robocompose serve --workers 2` (query processes)" in text and "500 requests per endpoint from 8" in text
    assert "measured by the ergodic optimiser" not in text  # an endpoint not benchmarked has no row
