"""The `robocompose` command. Each concept registers its own sub-commands; heavy imports wait for a handler."""

from __future__ import annotations

import argparse
import importlib
import json
import sys

COMMAND_MODULES = ("robocompose.grammar.cli", "robocompose.sim.cli", "robocompose.dataset.cli",
                   "robocompose.teams.cli", "robocompose.evaluation.cli", "robocompose.modular.cli",
                   "robocompose.latent.cli", "robocompose.glso.cli", "robocompose.serve.cli")
# `robocompose compose PROBLEM ...`: real-time composition with a trained EG-GAN generator, one module per problem
COMPOSE_MODULES = ("robocompose.modular.compose", "robocompose.teams.compose")


def _profile(args: argparse.Namespace) -> int:
    from robocompose.params import write_profile

    print(json.dumps({"params": str(write_profile(args.name)), "profile": args.name}))
    return 0


def parser() -> argparse.ArgumentParser:
    from robocompose.arguments import Parser  # one-line errors, for every sub-parser too (add_subparsers)

    top = Parser(prog="robocompose", description="Robot composition learning (GLSO, EG-GAN).")
    commands = top.add_subparsers(dest="command", required=True)
    profile = commands.add_parser("profile", help="switch params.yaml to a profile (default, paper, smoke); every "
                                  "section is checked before params.yaml is written")
    profile.add_argument("name", help="a file name under profiles/, without .yaml")
    profile.set_defaults(handler=_profile)
    for module in COMMAND_MODULES:
        importlib.import_module(module).register(commands)
    compose = commands.add_parser("compose", help="designs for a task in milliseconds from a trained EG-GAN generator")
    problems = compose.add_subparsers(dest="compose_problem", required=True)
    for module in COMPOSE_MODULES:
        importlib.import_module(module).register(problems)
    return top


def main(argv: list[str] | None = None) -> int:
    """Run one command. Bad input (the project's InputError) prints one line and returns 2, as argparse does;
    Ctrl-C prints one line and returns 130 (outputs are written atomically: each is whole or absent)."""
    from robocompose.io.errors import INPUT_ERROR_EXIT, INTERRUPTED_EXIT, InputError, error_line, interrupted_line
    from robocompose.io.quiet import quiet_pybullet

    quiet_pybullet()  # pybullet, when a command imports it, without its banner: nothing before the error line
    try:
        args = parser().parse_args(argv)
        return int(args.handler(args) or 0)
    except InputError as err:
        print(error_line("robocompose", err), file=sys.stderr)
        return INPUT_ERROR_EXIT
    except KeyboardInterrupt:
        print(interrupted_line("robocompose"), file=sys.stderr)
        return INTERRUPTED_EXIT


def run() -> int:
    """The `robocompose` program: `main` in a process with the pinned CPU dispatch (io.dispatch), for the same
    bytes on every machine. Only the program's own process is re-executed: callers of `main` are left alone."""
    from robocompose.io.dispatch import pin_dispatch

    pin_dispatch()
    return main()


if __name__ == "__main__":
    sys.exit(run())
