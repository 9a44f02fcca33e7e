"""mjchar: physics-based character control on MuJoCo.

This module only builds the parser from the subcommand modules listed in
:mod:`mjchar.commands` (``python -m mjchar`` runs it) and turns project errors into one-line
messages with exit status 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from mjchar.bvh.errors import MjcharError

from .commands import COMMANDS


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit status 2 (argparse's own convention)
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="mjchar", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                parser_class=_Parser)
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"mjchar.commands.{name}")
        except ModuleNotFoundError as e:
            if e.name == f"mjchar.commands.{name}":
                continue  # subcommand not built yet
            raise
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except MjcharError as e:
        print(f"mjchar {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130

