"""Shared fixtures: the two reference designs of the RoboGrammar/GLSO papers; a Foxglove validator of MCAP logs;
the bad-input check of the `robocompose` command; tests marked exclusive run alone under pytest-xdist."""

import contextlib
import fcntl
import json
import os
from pathlib import Path

import jsonschema
import pytest
from mcap.reader import make_reader

from robocompose.grammar.references import REFERENCE_DESIGNS
from robocompose.grammar.tree import DesignTree
from robocompose.io.mcap_log import SCALARS, SCALARS_SCHEMA, foxglove_schema_bytes

# --- wall-clock bounds under pytest-xdist (`make test`: two workers) ---


@contextlib.contextmanager
def _room(directory: Path, alone: bool):
    """Shared by every worker's tests, or held alone (a test marked exclusive): flock on two files in the run's
    temporary directory. The turnstile stops new tests from entering while an exclusive one waits for the room."""
    with (directory / "exclusive.turnstile").open("a") as turnstile, (directory / "exclusive.room").open("a") as room:
        fcntl.flock(turnstile, fcntl.LOCK_EX)
        if not alone:
            fcntl.flock(turnstile, fcntl.LOCK_UN)
        fcntl.flock(room, fcntl.LOCK_EX if alone else fcntl.LOCK_SH)
        yield  # closing the files releases both locks


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """Under pytest-xdist, a test marked exclusive (it times itself against a bound) runs while no other worker
    runs a test (setup, call and teardown, module fixtures included): the other core's work would count in its
    time. Without xdist (`python -m pytest`) nothing changes."""
    if "PYTEST_XDIST_WORKER" not in os.environ or not item.config.getoption("basetemp"):
        return (yield)
    with _room(Path(item.config.getoption("basetemp")).parent, item.get_closest_marker("exclusive") is not None):
        return (yield)


FLAT_REFERENCE = REFERENCE_DESIGNS["robogrammar_flat"]
RIDGED_REFERENCE = REFERENCE_DESIGNS["robogrammar_ridged"]


@pytest.fixture(params=[FLAT_REFERENCE, RIDGED_REFERENCE], ids=["flat", "ridged"])
def reference_rules(request) -> str:
    return request.param


def reversed_siblings(tree: DesignTree) -> DesignTree:
    """The same design with every node's children in reverse order (as a decoder may order them)."""
    order, parents, queue = [], [], [(0, -1)]
    while queue:
        node, parent = queue.pop(0)
        order.append(node)
        parents.append(parent)
        queue.extend((j, len(order) - 1) for j in reversed(tree.children(node)))
    return DesignTree(tuple(parents), tuple(tree.tokens[i] for i in order))


@pytest.fixture
def reorder():
    return reversed_siblings


def official_schema(name: str) -> dict:
    """The published schema of message `name`: Foxglove's vendored files, or the project's own Scalars schema."""
    return SCALARS_SCHEMA if name == SCALARS else json.loads(foxglove_schema_bytes(name))


def assert_valid_foxglove_log(path: Path) -> int:
    """Every message of the MCAP log at `path` validates against the official schema of its name (the draft the
    schema declares; Draft 2020-12 if none), and each channel embeds exactly that schema. Returns the count."""
    checked = 0
    with Path(path).open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            assert schema is not None and schema.encoding == "jsonschema" and channel.message_encoding == "json"
            official = official_schema(schema.name)
            assert json.loads(schema.data) == official, f"{channel.topic}: embedded schema is not {schema.name}'s"
            validator = jsonschema.validators.validator_for(official, default=jsonschema.Draft202012Validator)
            validator.check_schema(official)
            error = jsonschema.exceptions.best_match(validator(official).iter_errors(json.loads(message.data)))
            assert error is None, f"{channel.topic} at {message.log_time} ns: {error.json_path}: {error.message}"
            checked += 1
    assert checked > 0
    return checked


@pytest.fixture
def valid_foxglove_log():
    """assert_valid_foxglove_log(path): every message matches the official schema of its name."""
    return assert_valid_foxglove_log


# --- a page in a real browser (headless Chromium over the DevTools protocol) ---


def _chromium() -> str:
    import os
    import shutil

    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if found is None:
        if os.environ.get("CI"):
            pytest.fail("chromium is not installed (.ci/run installs it from the distribution's packages)")
        pytest.skip("chromium is not installed (apt-get install chromium)")
    return found


def _cdp(ws_url: str, page_url: str, expression: str) -> dict:
    """Open `page_url` in the browser tab at `ws_url` (DevTools protocol) and evaluate `expression`."""
    import json

    from websockets.sync.client import connect

    events: set[str] = set()
    with connect(ws_url, max_size=None, open_timeout=30) as ws:
        def call(ident: int, method: str, **params) -> dict:
            ws.send(json.dumps({"id": ident, "method": method, "params": params}))
            while True:
                message = json.loads(ws.recv(timeout=60))
                if message.get("id") == ident:
                    assert "error" not in message, message
                    return message["result"]
                events.add(message.get("method", ""))

        call(1, "Page.enable")
        call(2, "Page.navigate", url=page_url)
        while "Page.loadEventFired" not in events:
            events.add(json.loads(ws.recv(timeout=60)).get("method", ""))
        result = call(3, "Runtime.evaluate", expression=expression, awaitPromise=True, returnByValue=True)
    return json.loads(result["result"]["value"])


def check_in_browser(page: Path | str, expression: str, profile: Path) -> dict:
    """The JSON value of `expression` (a JS promise of a JSON string) on `page` (a local file or a loopback URL) in
    headless Chromium."""
    import json
    import socket
    import subprocess
    import time
    import urllib.request

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    browser = subprocess.Popen([_chromium(), "--headless=new", "--no-sandbox", "--disable-gpu",
                                f"--remote-debugging-port={port}", "--remote-debugging-address=127.0.0.1",
                                f"--user-data-dir={profile}", "about:blank"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=2) as response:
                    pages = [t for t in json.load(response) if t["type"] == "page"]
                if pages:
                    break
            except OSError:
                pass
            assert time.monotonic() < deadline and browser.poll() is None, "chromium did not start"
            time.sleep(0.2)
        return _cdp(pages[0]["webSocketDebuggerUrl"], page if isinstance(page, str) else page.as_uri(), expression)
    finally:
        browser.terminate()
        browser.wait(timeout=30)


@pytest.fixture
def in_browser(tmp_path):
    """`in_browser(page, expression)`: what `expression` evaluates to on `page` (a local file or a loopback URL) in
    headless Chromium."""
    return lambda page, expression: check_in_browser(page, expression, tmp_path / "browser-profile")
@pytest.fixture
def cli_error(capsys):
    """cli_error(argv, *fragments): run `robocompose argv` in-process; assert it exits 2 with exactly one line on
    stderr, `robocompose: error: ...` (argparse's errors too: no usage block), that holds every fragment, no
    traceback, nothing on stdout. Returns the error line."""
    from robocompose.cli import main

    def run(argv: list[str], *fragments: str) -> str:
        try:
            code = main(argv)
        except SystemExit as exit_:  # argparse's own errors
            code = exit_.code
        out, err = capsys.readouterr()
        lines = err.strip().splitlines()
        assert code == 2, f"exit code {code}, stderr {err!r}"
        assert out == "" and "Traceback" not in err, err
        assert len(lines) == 1 and lines[0].startswith("robocompose: error: "), err
        line = lines[0]
        assert all(f in line for f in fragments), line
        return line

    return run


# --- a real Dask cluster on loopback ---


@pytest.fixture(scope="session")
def dask_address():
    """The scheduler address of a LocalCluster on loopback (2 worker processes, one thread each), shared by the
    session's tests."""
    from dask.distributed import LocalCluster

    # the scheduler's HTTP server on a free loopback port: None would try 8787 (taken by any other cluster here)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0", silence_logs=40) as cluster:
        yield cluster.scheduler_address


# --- a tiny copy of the project ---


def copy_of_project(root: Path, params: dict, commit: bool = False) -> Path:
    """The project's tracked files (as in the working tree) in a new git repo at `root`, with params.yaml from
    profiles/default.yaml and `params` merged into it section by section (nested dicts merged, not replaced).
    `commit`: commit everything once (dvclive, in the train_vae stage, needs a revision)."""
    import shutil
    import subprocess

    import yaml

    source = Path(__file__).resolve().parents[1]
    files = subprocess.run(["git", "ls-files"], cwd=source, check=True, capture_output=True, text=True).stdout.split()
    for name in files:
        if (source / name).is_file():
            (root / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source / name, root / name)
    document = yaml.safe_load((root / "profiles" / "default.yaml").read_text())

    def merge(into: dict, values: dict) -> None:
        for key, value in values.items():
            if isinstance(value, dict):
                merge(into[key], value)
            else:
                into[key] = value

    merge(document, params)
    (root / "params.yaml").write_text(yaml.safe_dump(document))
    commands = [["init", "-q"], *([["add", "-A"], ["commit", "-qm", "tiny copy"]] if commit else [])]
    for command in commands:
        subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *command], cwd=root, check=True,
                       capture_output=True)
    return root


@pytest.fixture(scope="session")
def copy_project():
    """copy_project(root, params, commit=False): a tiny copy of the project (see copy_of_project)."""
    return copy_of_project


# --- tiny trained generators (the compose commands and the service) ---


def tiny_teams_params(experiments: dict | None = None, eggan: dict | None = None, chips: dict | None = None) -> str:
    """params.yaml of a tiny teams world (4 synthetic chips, 2 of them test, K = 3), `experiments`, `eggan` and
    `chips` overriding its sections' settings."""
    import yaml

    return yaml.safe_dump({
        "teams": {"chips": {"n_synthetic": 4, "seed": 1, **(chips or {})},
                  "decompose": {"n_regions": 3, "test_fraction": 0.5},
                  "coverage": {"iterations": 2, "n_observations": 4},
                  "experiments": {"populations": [4, 6], "generations": 2, "table_5_4_chips": 1,
                                  "table_5_5_chips": 1, "seeds": [0], "budgets": [3, 6], **(experiments or {})},
                  "eggan": {"iterations": 2, "batch": 8, "tasks": 2, "samples": 16, "checkpoint_every": 1,
                            "latent": 4, "fitness": {}, **(eggan or {})}},
        "compute": {"workers": 1}})


@pytest.fixture
def teams_params():
    """teams_params(experiments=None, eggan=None, chips=None): the YAML of `tiny_teams_params`."""
    return tiny_teams_params


@pytest.fixture(scope="session")
def tiny_teams_model(tmp_path_factory):
    """A generator file from a two-iteration training on two small chips (K = 3)."""
    import dataclasses

    from robocompose.eggan.networks import NetworkConfig
    from robocompose.eggan.train import TrainConfig, train
    from robocompose.teams.chips import synthetic_chip
    from robocompose.teams.decompose import DecomposeConfig, decompose_chip
    from robocompose.teams.eggan_problem import TeamsProblem
    from robocompose.teams.ergodic import CoverageConfig
    from robocompose.teams.generative import save_teams_generator
    from robocompose.teams.params import EgganConfig

    coverage, decompose = CoverageConfig(iterations=3, n_observations=5), DecomposeConfig(n_regions=3)
    chips = [synthetic_chip(4, index, size=40) for index in range(2)]
    problem = TeamsProblem([(chip, decompose_chip(chip, decompose)) for chip in chips], coverage)
    trained = train(problem, NetworkConfig(latent=4, hidden=16),
                    TrainConfig(iterations=2, batch=8, tasks=2, evolution="nsga2", log_every=1, checkpoint_every=2))
    params = {"coverage": dataclasses.asdict(coverage), "decompose": dataclasses.asdict(decompose),
              "eggan": dataclasses.asdict(EgganConfig(samples=16))}
    path = tmp_path_factory.mktemp("model") / "teams.pt"
    save_teams_generator(trained, problem, params, {}, path)
    return path


@pytest.fixture(scope="session")
def tiny_modular_model(tmp_path_factory):
    """An untrained small modular generator file (seeded): valid answers, fast to load."""
    import torch

    from robocompose.eggan.networks import Generator, NetworkConfig
    from robocompose.eggan.query import save_generator
    from robocompose.modular.evaluate import EvalSettings, FitnessRule
    from robocompose.modular.params import ExperimentsConfig, ModularParams
    from robocompose.modular.plugins.eggan_problem import FitnessConfig, ModularEgganProblem

    torch.manual_seed(0)
    problem = ModularEgganProblem(ModularParams(EvalSettings(), FitnessRule(), ExperimentsConfig()), FitnessConfig())
    generator = Generator(problem.task_shape, problem.design_shape, NetworkConfig(latent=8, hidden=16)).eval()
    return save_generator(generator, problem, tmp_path_factory.mktemp("modular") / "g.pt", {"run_key": "test"})


@pytest.fixture
def one_torch_thread():
    """One torch thread for the test (a module opts in with `pytestmark = pytest.mark.usefixtures(...)`): small
    tensors and GPs are fastest on one, a busy machine's second core does not stall them, and a run
    (`runs.run_search`) has one."""
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)
