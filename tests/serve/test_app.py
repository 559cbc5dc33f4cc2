"""The composition service over real HTTP on loopback: answers equal the CLI's, every bad input a 4xx naming its
field, concurrent and slow requests, the page in headless Chromium."""

from __future__ import annotations

import io
import json
import re
import threading
import time
import urllib.error
import urllib.request
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from PIL import Image

from robocompose.cli import main
from robocompose.serve.app import MAX_BODY_BYTES, create_app
from robocompose.serve.cli import listen, load_models
from robocompose.teams.chips import CLASS_COLOURS_RGB, label_png_bytes, synthetic_chip


@pytest.fixture(scope="module")
def server(tiny_modular_model, tiny_teams_model):
    """The service on a free loopback port (uvicorn in a thread): the shipped models and the tiny ones ("tiny")."""
    import uvicorn

    app = create_app(load_models([f"tiny={tiny_modular_model}"], [f"tiny={tiny_teams_model}"], None))
    listener = listen("127.0.0.1", 0)
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", access_log=False))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [listener]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:
        assert time.monotonic() < deadline and thread.is_alive(), "the server did not start"
        time.sleep(0.05)
    yield f"http://127.0.0.1:{listener.getsockname()[1]}"
    server.should_exit = True
    thread.join(timeout=10)


def call(url: str, body: bytes | dict | None = None, content_type: str | None = None) -> tuple[int, dict | bytes]:
    """(status, JSON answer or raw bytes) of a GET (no body) or POST; a dict body is sent as JSON."""
    if isinstance(body, dict):
        body, content_type = json.dumps(body).encode(), "application/json"
    request = urllib.request.Request(url, data=body, method="GET" if body is None else "POST")
    if content_type:
        request.add_header("Content-Type", content_type)
    try:
        with urllib.request.urlopen(request, timeout=60) as response:
            status, data, kind = response.status, response.read(), response.headers.get("content-type", "")
    except urllib.error.HTTPError as error:
        status, data, kind = error.code, error.read(), error.headers.get("content-type", "")
    return status, json.loads(data) if kind.startswith("application/json") else data


def png(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(array).save(buffer, format="PNG")
    return buffer.getvalue()


def npy(array) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def cli_json(argv: list[str], capsys) -> dict:
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


CHIP = label_png_bytes(synthetic_chip(7).classes)


def test_health_reports_each_model_with_the_digest_of_its_file(server, tiny_modular_model):
    import hashlib

    status, answer = call(f"{server}/health")
    assert status == 200 and answer["status"] == "ok"
    tiny = answer["models"]["modular"]["tiny"]
    assert tiny["file"] == str(tiny_modular_model) and tiny["run_key"] == "test"
    assert tiny["sha256"] == hashlib.sha256(tiny_modular_model.read_bytes()).hexdigest()
    assert set(answer["models"]["teams"]) == {"shipped", "tiny"} and answer["limits"]["body_bytes"] == MAX_BODY_BYTES


def test_a_modular_query_by_seed_is_the_clis_answer(server, capsys):
    status, answer = call(f"{server}/compose/modular", {"terrain_seed": 1003, "k": 6, "max": {"leg": 2}, "seed": 4})
    cli = cli_json(["compose", "modular", "--terrain-seed", "1003", "--k", "6", "--max", "leg=2", "--seed", "4"],
                   capsys)
    assert status == 200 and answer["designs"] == cli["designs"] and len(answer["designs"]) == 6
    assert all(d["design"].count("l") <= 2 for d in answer["designs"])


def test_a_height_map_as_json_or_npy_is_the_clis_answer(server, tmp_path, capsys):
    heights = np.random.default_rng(0).uniform(0, 0.15, (50, 20))
    path = tmp_path / "map.npy"
    np.save(path, heights)
    cli = cli_json(["compose", "modular", "--heightmap", str(path), "--k", "4"], capsys)
    as_json = call(f"{server}/compose/modular", {"heightmap": heights.tolist(), "k": 4})
    as_npy = call(f"{server}/compose/modular?k=4", npy(heights), "application/x-npy")
    assert as_json[0] == as_npy[0] == 200
    assert as_json[1]["designs"] == as_npy[1]["designs"] == cli["designs"]


def test_table_distances_are_the_committed_tables(server):
    from robocompose.modular.cli import _params
    from robocompose.modular.truth import read_committed

    status, answer = call(f"{server}/compose/modular", {"terrain_seed": 1000, "k": 5, "distances": "table"})
    params = _params(None)
    table = read_committed(1000, params.eval, params.fitness).set_index("design").distance
    assert status == 200 and [d["distance"] for d in answer["designs"]] == [table[d["design"]]
                                                                           for d in answer["designs"]]


def test_a_measured_teams_query_is_the_clis_answer(server, tmp_path, capsys):
    path = tmp_path / "field.png"
    path.write_bytes(CHIP)
    cli = cli_json(["compose", "teams", "--chip", str(path), "--budget", "30"], capsys)
    status, answer = call(f"{server}/compose/teams?name=field&budget=30&measure=true", CHIP, "image/png")
    assert status == 200 and answer["chip"] == cli["chip"] == "field-000000"
    assert answer["allocation"] == cli["allocation"] and answer["hypervolume"] == cli["hypervolume"]
    assert len(answer["centres"]) == len(answer["shares"]) == answer["regions"]


def test_an_unmeasured_teams_query_answers_the_distinct_allocations_within_the_budget(server):
    status, answer = call(f"{server}/compose/teams?budget=12&draw=true", CHIP, "image/png")
    counts = [np.array(a["counts"]) for a in answer["allocations"]]
    assert status == 200 and not answer["measured"] and counts
    assert all(c.sum() == a["deployment_cost"] <= 12 for c, a in zip(counts, answer["allocations"], strict=True))
    assert len({c.tobytes() for c in counts}) == len(counts) <= answer["distinct"]
    assert answer["drawing"].startswith("data:image/png;base64,")


def test_pictures_and_synthetic_chips_are_pngs(server):
    status, picture = call(f"{server}/picture/modular?design=lnwwnl&terrain_seed=1000")
    assert status == 200 and Image.open(io.BytesIO(picture)).size == (480, 360)
    assert call(f"{server}/chips/synthetic/7") == (200, CHIP)


HEIGHTS = np.zeros((50, 20))
NAN_BODY = json.dumps({"heightmap": HEIGHTS.tolist()}).replace("0.0", "NaN", 1).encode()
WRONG_COLOUR = np.full((300, 300, 3), (1, 2, 3), dtype=np.uint8)


def _jpeg() -> bytes:
    buffer = io.BytesIO()
    Image.new("RGB", (300, 300)).save(buffer, format="JPEG")
    return buffer.getvalue()


# (path, body, content type, status, the error's start)
BAD = {
    "seed text": ("/compose/modular", {"terrain_seed": "abc"}, None, 400, "terrain_seed: expected an integer"),
    "seed negative": ("/compose/modular", {"terrain_seed": -1}, None, 400, "terrain_seed: expected an integer"),
    "seed bool": ("/compose/modular", {"terrain_seed": True}, None, 400, "terrain_seed: expected an integer"),
    "seed float": ("/compose/modular", {"terrain_seed": 1.5}, None, 400, "terrain_seed: expected an integer"),
    "no terrain": ("/compose/modular", {"k": 3}, None, 400, "terrain_seed: expected a terrain seed or a heightmap"),
    "both": ("/compose/modular", {"terrain_seed": 1, "heightmap": HEIGHTS.tolist()}, None, 400, "terrain_seed: "),
    "k zero": ("/compose/modular", {"terrain_seed": 1, "k": 0}, None, 400, "k: expected an integer in 1..256"),
    "k huge": ("/compose/modular", {"terrain_seed": 1, "k": 10**9}, None, 400, "k: expected an integer in 1..256"),
    "samples": ("/compose/modular", {"terrain_seed": 1, "samples": 10**7}, None, 400, "samples: expected"),
    "caps name": ("/compose/modular", {"terrain_seed": 1, "max": "arm=2"}, None, 400, "max 'arm=2': expected"),
    "caps value": ("/compose/modular", {"terrain_seed": 1, "max": {"leg": "two"}}, None, 400, "max: expected"),
    "distances": ("/compose/modular", {"terrain_seed": 1, "distances": "magic"}, None, 400, "distances: expected"),
    "no table": ("/compose/modular", {"terrain_seed": 5, "distances": "table"}, None, 400,
                 "distances: no committed exhaustive table of terrain seed 5"),
    "unknown field": ("/compose/modular", {"terrain_seed": 1, "colour": 1}, None, 400, "colour: unknown field"),
    "unknown model": ("/compose/modular", {"terrain_seed": 1, "model": "nope"}, None, 404, "model: 'nope' unknown"),
    "a path": ("/compose/modular", {"heightmap": "/etc/passwd"}, None, 400,
               "heightmap: expected a 50 x 20 array of numbers (metres), found a string"),
    "ragged": ("/compose/modular", {"heightmap": [[0.0, 1.0], [0.0]]}, None, 400, "heightmap: expected a 50 x 20"),
    "shape": ("/compose/modular", {"heightmap": np.zeros((20, 50)).tolist()}, None, 400,
              "heightmap: expected shape (50, 20)"),
    "NaN": ("/compose/modular", NAN_BODY, "application/json", 400, "heightmap: expected finite numbers"),
    "negative": ("/compose/modular", {"heightmap": np.full((50, 20), -1.0).tolist()}, None, 400,
                 "heightmap: heights expected in [0, "),
    "absurd": ("/compose/modular", {"heightmap": np.full((50, 20), 1e9).tolist()}, None, 400,
               "heightmap: heights expected in [0, "),
    "not json": ("/compose/modular", b"{terrain_seed: 1", "application/json", 400, "body: not valid JSON"),
    "json list": ("/compose/modular", b"[1, 2]", "application/json", 400, "body: expected a JSON object"),
    "text type": ("/compose/modular", b"terrain_seed=1", "text/plain", 415, "body: content type 'text/plain'"),
    "npy cut": ("/compose/modular", npy(HEIGHTS)[:100], "application/x-npy", 400, "body: not a .npy array file"),
    "npy pickle": ("/compose/modular", b"\x80\x04\x95", "application/x-npy", 400, "body: not a .npy array file"),
    "npy path": ("/compose/modular", b"/tmp/map.npy", "application/x-npy", 400, "body: not a .npy array file"),
    "npy shape": ("/compose/modular", npy(np.zeros(3)), "application/x-npy", 400, "body: expected shape (50, 20)"),
    "npy text": ("/compose/modular", npy(np.array(["a"] * 1000).reshape(50, 20)), "application/x-npy", 400,
                 "body: expected real numbers"),
    "chip empty": ("/compose/teams", b"", "image/png", 400, "body: empty, expected a DroneDeploy label PNG"),
    "chip text": ("/compose/teams", b"not a picture", "image/png", 400, "body: not a readable image"),
    "chip jpeg": ("/compose/teams", _jpeg(), "image/jpeg", 400, "body: a JPEG image, expected a DroneDeploy label PNG"),
    "chip palette": ("/compose/teams", png(WRONG_COLOUR), "image/png", 400, "body: pixel (row 0, col 0) has colour "
                     "(1, 2, 3), expected one of the DroneDeploy label colours"),
    "chip small": ("/compose/teams", label_png_bytes(synthetic_chip(1, size=100).classes), "image/png", 400,
                   "body: no 300 x 300 window without IGNORE pixels"),
    "chip cut": ("/compose/teams", CHIP[: len(CHIP) // 2], "image/png", 400, "body: not a readable image"),
    "chip pixels": ("/compose/teams", png(np.full((3000, 3000, 3), CLASS_COLOURS_RGB[4], dtype=np.uint8)),
                    "image/png", 400, "body: more than 4,194,304 pixels"),
    "budget zero": ("/compose/teams?budget=0", CHIP, "image/png", 400, "budget: expected an integer in 1.."),
    "budget text": ("/compose/teams?budget=lots", CHIP, "image/png", 400, "budget: expected an integer in 1.."),
    "measure": ("/compose/teams?measure=maybe", CHIP, "image/png", 400, "measure: expected true or false"),
    "chip name": ("/compose/teams?name=../etc/passwd", CHIP, "image/png", 400, "name: expected 1 to 64 letters"),
    "teams model": ("/compose/teams?model=nope", CHIP, "image/png", 404, "model: 'nope' unknown"),
    "teams field": ("/compose/teams?chip=/etc/passwd", CHIP, "image/png", 400, "chip: unknown query parameter"),
    "design": ("/picture/modular?design=xyz", None, None, 400, "design 'xyz': expected 6 letters"),
    "picture seed": ("/picture/modular?design=llllll&terrain_seed=-2", None, None, 400, "terrain_seed: expected"),
    "chip seed": ("/chips/synthetic/abc", None, None, 400, "seed: expected an integer"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_input_is_a_4xx_with_one_line_naming_its_field(server, case):
    path, body, kind, status, start = BAD[case]
    answer = call(f"{server}{path}", body, kind)
    assert answer[0] == status and set(answer[1]) == {"error"}, answer
    assert answer[1]["error"].startswith(start) and "\n" not in answer[1]["error"], answer[1]["error"]


@pytest.mark.parametrize("path", ["/compose/modular", "/compose/teams"])
def test_an_upload_over_the_limit_is_refused_before_its_body_is_read(server, path):
    import http.client

    connection = http.client.HTTPConnection(server.removeprefix("http://"), timeout=30)
    connection.putrequest("POST", path)
    connection.putheader("Content-Type", "application/x-npy")
    connection.putheader("Content-Length", str(MAX_BODY_BYTES + 1))
    connection.endheaders()  # no body sent: the answer comes from the declared length alone
    response = connection.getresponse()
    assert response.status == 413 and json.loads(response.read()) == {
        "error": f"body: {MAX_BODY_BYTES + 1:,} bytes, expected at most {MAX_BODY_BYTES:,} bytes"}
    connection.close()


def test_concurrent_good_requests_are_answered_right_beside_malformed_ones(server):
    good = [("/compose/modular", {"terrain_seed": 1000 + i % 4, "k": 5, "model": "tiny"}, None) for i in range(16)]
    good += [("/compose/teams?model=tiny&budget=20", CHIP, "image/png")] * 6
    bad = [BAD[case][:3] for case in ("NaN", "chip palette", "not json", "chip cut", "npy pickle")]
    expected = [call(f"{server}{path}", body, kind)[1] for path, body, kind in good[:4] + good[16:17]]
    with ThreadPoolExecutor(8) as pool:
        answers = list(pool.map(lambda request: call(f"{server}{request[0]}", *request[1:]), good + bad * 2))
    for (status, answer), index in zip(answers[:len(good)], [i % 4 for i in range(16)] + [4] * 6, strict=True):
        keys = ("designs",) if "designs" in answer else ("allocations", "centres")
        assert status == 200 and all(answer[k] == expected[index][k] for k in keys)
    assert all(status == 400 for status, _ in answers[len(good):])


def test_a_slow_measured_front_does_not_hold_up_fast_queries(server):
    finished: dict[str, float] = {}

    def slow() -> None:  # the shipped generator's front: ~350 teams optimised, seconds
        assert call(f"{server}/compose/teams?measure=true&seed=3", CHIP, "image/png")[0] == 200
        finished["slow"] = time.monotonic()

    thread = threading.Thread(target=slow)
    thread.start()
    time.sleep(0.2)
    fast = [call(f"{server}/compose/modular", {"terrain_seed": 1000 + i, "k": 3})[0] for i in range(5)]
    finished["fast"] = time.monotonic()
    thread.join()
    assert fast == [200] * 5 and finished["fast"] < finished["slow"]


def test_the_page_draws_an_uploaded_chip_and_the_designs_of_a_terrain(server, in_browser):
    expression = """(async () => {
      const wait = async (ready) => {
        for (let i = 0; i < 600 && !ready(); i++) await new Promise(r => setTimeout(r, 100));
      };
      const chip = await (await fetch('/chips/synthetic/7')).blob();
      const transfer = new DataTransfer();
      transfer.items.add(new File([chip], 'field.png', {type: 'image/png'}));
      const input = document.getElementById('chip');
      input.files = transfer.files;
      input.dispatchEvent(new Event('change'));
      const drawn = () => document.querySelector('#teams-figure img');
      await wait(() => drawn() && drawn().complete && drawn().naturalWidth > 0);
      document.querySelector('#modular-form button').click();
      const pictures = () => [...document.querySelectorAll('#modular-designs img')];
      await wait(() => pictures().length && pictures().every(p => p.complete && p.naturalWidth > 0));
      return JSON.stringify({teams: document.getElementById('teams-status').textContent,
        width: drawn() ? drawn().naturalWidth : 0,
        labels: [...document.querySelectorAll('.region-label')].map(t => t.textContent),
        modular: document.getElementById('modular-status').textContent,
        pictures: pictures().map(p => p.naturalWidth)});
    })()"""
    seen = in_browser(f"{server}/", expression)
    assert seen["teams"].startswith("chip field-000000, 8 regions; best within 30 robots"), seen["teams"]
    assert "latency" in seen["teams"]
    assert seen["width"] == 300 and len(seen["labels"]) == 8
    assert all(re.fullmatch(r"G\d+ A\d+ Aq\d+", label) for label in seen["labels"]), seen["labels"]
    assert seen["modular"].startswith("10 designs, latency") and seen["pictures"] == [480] * 10
