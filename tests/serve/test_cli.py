"""`robocompose serve`: a real process on loopback answers; a bad model flag or port stops it before it listens."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import urllib.request
from concurrent.futures import ThreadPoolExecutor

import pytest

from robocompose.serve.cli import named_models


def test_serve_starts_a_real_server_on_loopback_that_answers(tiny_modular_model):
    process = subprocess.Popen([sys.executable, "-m", "robocompose.cli", "serve", "--port", "0",
                                "--modular-model", f"tiny={tiny_modular_model}"],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        started = json.loads(process.stdout.readline())
        assert started["serving"].startswith("http://127.0.0.1:")
        assert started["models"]["modular"] == ["shipped", "tiny"]
        with urllib.request.urlopen(started["serving"] + "health", timeout=30) as response:
            assert json.load(response)["models"]["modular"]["tiny"]["file"] == str(tiny_modular_model)
    finally:
        process.terminate()
        process.wait(timeout=30)


def test_named_models_keep_the_shipped_one_and_add_each_name(tmp_path):
    path = tmp_path / "g.pt"
    path.write_bytes(b"")
    assert named_models([f"field={path}"], "--teams-model") == {"shipped": None, "field": path}


def test_bad_model_flags_and_ports_exit_2_before_listening(tmp_path, cli_error):
    cli_error(["serve", "--modular-model", "nameless"], "--modular-model 'nameless': expected NAME=PATH")
    cli_error(["serve", "--teams-model", f"x={tmp_path}"], f"--teams-model 'x={tmp_path}': {tmp_path}: a directory")
    cli_error(["serve", "--modular-model", "x=/no/such.pt"], "no such file, expected a generator file")
    cli_error(["serve", "--port", "-1"], "argument --port", "expected an integer >= 0")
    cli_error(["serve", "--port", "70000"], "argument --port", "expected a port in 0..65535, found 70000")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        used = taken.getsockname()[1]
        cli_error(["serve", "--port", str(used)], f"--host 127.0.0.1 --port {used}: cannot listen there")


def _designs(url: str, seed: int) -> list:
    request = urllib.request.Request(url + "compose/modular", json.dumps({"terrain_seed": seed}).encode(),
                                     {"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=60) as response:
        return json.load(response)["designs"]


@pytest.mark.slow  # two query processes start (~15 s)
def test_query_processes_answer_as_the_http_process_does(tiny_modular_model):
    # Both servers run under the command's CPU-dispatch pin, so their answers compare byte for byte; this test's
    # own process is not pinned and may round the scores' last digit otherwise (AVX-512 machines).
    servers = [subprocess.Popen([sys.executable, "-m", "robocompose.cli", "serve", "--port", "0", "--workers", n],
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True) for n in ("2", "0")]
    try:
        pooled, alone = (json.loads(server.stdout.readline())["serving"] for server in servers)
        with urllib.request.urlopen(pooled + "health", timeout=60) as response:
            pids = json.load(response)["query_processes"]
        assert len(set(pids)) == 2 and servers[0].pid not in pids
        with ThreadPoolExecutor(8) as pool:
            answers = list(pool.map(lambda seed: _designs(pooled, seed), [1000 + i % 3 for i in range(24)]))
        expected = {seed: _designs(alone, seed) for seed in (1000, 1001, 1002)}
        assert all(answer == expected[1000 + i % 3] for i, answer in enumerate(answers))
    finally:
        for server in servers:
            server.terminate()
            server.wait(timeout=30)
