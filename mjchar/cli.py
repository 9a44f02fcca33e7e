"""mjchar: physics-based character control on MuJoCo.

This module only builds the parser from the subcommand modules listed in
:mod:`mjchar.commands` (``python -m mjchar`` runs it), turns project errors into one-line
messages with exit status 2, and ends quietly when its output is closed early
(``mjchar info clip.bvh | head``): no traceback, exit status 141 (128 + SIGPIPE, what the shell
reports for a program the closed pipe stopped).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from mjchar import __version__
from mjchar.bvh.errors import MjcharError

from .commands import COMMANDS
from .commands.suggest import argparse_message

#: exit status of a command whose standard output was closed before it finished (128 + SIGPIPE)
EXIT_BROKEN_PIPE = 141


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit status 2 (argparse's own convention)
        message = argparse_message(message, self._option_string_actions)
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="mjchar", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"mjchar {__version__}")
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
    parser.commands = sub.choices  # each subcommand's parser, for its own error messages
    return parser


def main(argv: list[str] | None = None) -> int:
    try:
        parser = build_parser()
        args, extra = parser.parse_known_args(argv)
        if extra:  # the subcommand's error: `mjchar run: error: unrecognized arguments: ...`
            parser.commands[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
        try:
            code = int(args.func(args) or 0)
        except MjcharError as e:
            print(f"mjchar {args.command}: error: {e}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print("interrupted", file=sys.stderr)
            return 130
        sys.stdout.flush()  # a closed pipe shows here, not at exit
        return code
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_BROKEN_PIPE


def _quiet_stdout() -> None:
    """Point standard output at the null device: Python flushes it again at exit, which would
    report the closed pipe a second time."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # no file descriptor (captured output): nothing to flush
        pass

