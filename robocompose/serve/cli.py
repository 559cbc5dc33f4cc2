"""`robocompose serve`: the composition service on loopback (see robocompose.serve.app for its endpoints).

    robocompose serve [--host 127.0.0.1] [--port 8000] [--modular-model NAME=PATH ...] [--teams-model NAME=PATH ...]

The shipped generators answer as the model "shipped"; each NAME=PATH adds one more (or replaces "shipped"). Every
model is loaded and checked before the server listens: a bad file stops the start with one line, exit 2.
"""

from __future__ import annotations

import argparse
import json
import re
import socket
from pathlib import Path

from robocompose.arguments import int_at_least
from robocompose.io.errors import InputError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add `serve` to the robocompose CLI."""
    serve = subparsers.add_parser("serve", help="the composition service (HTTP, loopback by default) and its page")
    serve.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1, this machine "
                       "only; 0.0.0.0 opens it to the network)")
    serve.add_argument("--port", type=port, default=8000, help="port (default 8000; 0: any free one)")
    serve.add_argument("--modular-model", action="append", default=[], metavar="NAME=PATH",
                       help="a modular generator file answering as model NAME (repeatable)")
    serve.add_argument("--teams-model", action="append", default=[], metavar="NAME=PATH",
                       help="a teams generator file answering as model NAME (repeatable)")
    serve.add_argument("--workers", type=int_at_least(0), default=0, help="query processes, each with its own copy "
                       "of the models, taking the fast queries request by request (default 0: the HTTP process "
                       "answers them; 2 on a 2-core machine answers more at once)")
    serve.add_argument("--params", type=Path, default=None, help="params file with a modular: section (default: "
                       "params.yaml if there is one, else the defaults); a file named here must exist")
    serve.set_defaults(handler=_serve)


def port(text: str) -> int:
    """argparse type of a TCP port, 0..65535 (0: any free one)."""
    value = int_at_least(0)(text)
    if value > 65535:
        raise argparse.ArgumentTypeError(f"expected a port in 0..65535, found {value}")
    return value


def named_models(pairs: list[str], flag: str) -> dict[str, Path | None]:
    """{"shipped": None (the shipped file), NAME: PATH, ...} from NAME=PATH flags, each file checked to exist."""
    models: dict[str, Path | None] = {"shipped": None}
    for pair in pairs:
        name, _, path = pair.partition("=")
        if not re.fullmatch(r"[A-Za-z0-9_.-]{1,64}", name) or not path:
            raise InputError(f"{flag} {pair!r}: expected NAME=PATH with NAME of letters, digits, '_', '.' or '-'")
        if not Path(path).is_file():
            found = "a directory" if Path(path).is_dir() else "no such file"
            raise InputError(f"{flag} {pair!r}: {path}: {found}, expected a generator file")
        models[name] = Path(path)
    return models


def load_models(modular: list[str], teams: list[str], params_file: Path | None):
    """The service's Models: every named generator loaded and checked (the teams ones with their own settings)."""
    import torch

    from robocompose.modular.cli import _params, params_source
    from robocompose.modular.compose import ModularComposer
    from robocompose.serve.app import Models
    from robocompose.teams.compose import TeamsComposer

    torch.set_num_threads(1)  # one core a query; the server overlaps queries instead
    modular_paths, teams_paths = named_models(modular, "--modular-model"), named_models(teams, "--teams-model")
    params = _params(params_file)
    return Models({name: ModularComposer.load(path, params) for name, path in modular_paths.items()},
                  {name: TeamsComposer.load(path) for name, path in teams_paths.items()},
                  f"{params_source(params_file)}.eval", (modular, teams, params_file and str(params_file)))


def listen(host: str, port: int) -> socket.socket:
    """A listening TCP socket at (host, port) for the server; InputError naming the flags if it cannot be had."""
    listener = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    # inherited by every connection: an answer's header and body go out at once, not 40 ms apart (Nagle's algorithm
    # holding the body until the client's delayed ACK of the header)
    listener.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    try:
        listener.bind((host, port))
        listener.listen(2048)  # connections wait in the backlog from now on: the server is reachable once this returns
    except OSError as err:
        listener.close()
        raise InputError(f"--host {host} --port {port}: cannot listen there ({err.strerror})") from None
    return listener


def _serve(args: argparse.Namespace) -> None:
    import sys

    import uvicorn

    from robocompose.serve.app import create_app

    listener = listen(args.host, args.port)  # the address first: a taken port stops the start before models load
    app = create_app(load_models(args.modular_model, args.teams_model, args.params), args.workers)
    sys.setswitchinterval(0.001)  # a slow query in a thread yields the interpreter to fast ones every millisecond
    host, port = listener.getsockname()[:2]
    print(json.dumps({"serving": f"http://{host}:{port}/", "query_processes": args.workers,
                      "models": {w: sorted(m) for w, m in (("modular", app.state.models.modular),
                                                           ("teams", app.state.models.teams))}}), flush=True)
    uvicorn.Server(uvicorn.Config(app, log_level="warning", access_log=False)).run(sockets=[listener])
