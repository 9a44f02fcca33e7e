"""mjchar: physics-based character control on MuJoCo.

This module only builds the parser from the subcommand modules listed in
:mod:`mjchar.commands` (``python -m mjchar`` runs it), turns project errors into one-line
messages with exit status 2, and ends quietly when its output is closed early
(``mjchar info clip.bvh | head``): no traceback, exit status 141 (128 + SIGPIPE, what the shell
reports for a program the closed pipe stopped).

Ctrl-C and SIGTERM end any command with one line and exit status 130 and 143 (128 + the
signal, the shell's convention): SIGTERM is raised as :class:`Terminated`, a
``KeyboardInterrupt``, so every atomic writer and video recorder removes its partial file on the
way out, as for Ctrl-C. An error message is always one line, cut to :data:`MAX_MESSAGE`
characters.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading

from mjchar import __version__
from mjchar.bvh.errors import MjcharError

from .commands import COMMANDS
from .commands.suggest import argparse_message

#: exit status of a command whose standard output was closed before it finished (128 + SIGPIPE)
EXIT_BROKEN_PIPE = 141
#: exit status after Ctrl-C (128 + SIGINT)
EXIT_INTERRUPTED = 130
#: exit status after SIGTERM (128 + SIGTERM)
EXIT_TERMINATED = 143
#: longest error message printed (a longer one is cut, saying how much was left out)
MAX_MESSAGE = 600


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread like Ctrl-C so that cleanup code runs."""


def _on_sigterm(signum, frame):
    raise Terminated()


def _printable(c: str) -> str:
    """A character as printed in an error line: itself, a space for a line break or tab, an
    escape (``\\x00``, ``\\udcff``) for anything else a terminal would not show."""
    if c.isprintable():
        return c
    if c.isspace():
        return " "
    return c.encode("unicode_escape").decode("ascii")


def one_line(message: str, limit: int = MAX_MESSAGE) -> str:
    """``message`` on one line (line breaks become spaces, runs of blanks one space, other
    control characters escapes), cut to ``limit`` characters with a note of how many were left
    out."""
    text = " ".join("".join(map(_printable, message)).split())
    if len(text) > limit:
        text = f"{text[:limit - 40].rstrip()} ... ({len(text) - limit + 40} more characters)"
    return text


def _signed_axes(argv: list[str]) -> list[str]:
    """``--up -y`` as ``--up=-y``: argparse would read a value that starts with ``-`` as an
    option."""
    out: list[str] = []
    for a in argv:
        if out and out[-1] == "--up" and a in ("-x", "-y", "-z"):
            out[-1] = f"--up={a}"
        else:
            out.append(a)
    return out


class _Parser(argparse.ArgumentParser):
    def parse_known_args(self, args=None, namespace=None):
        args = _signed_axes(sys.argv[1:] if args is None else list(args))
        return super().parse_known_args(args, namespace)

    def error(self, message: str):  # one line, exit status 2 (argparse's own convention)
        message = argparse_message(message, self._option_string_actions)
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The ``mjchar`` parser for the command line ``argv`` (default: every subcommand's own
    parser). Given ``argv``, only the subcommand it names gets its parser (which may import the
    controllers for its choices); the others are a name and their line of help
    (:data:`~mjchar.commands.COMMANDS`), so ``mjchar --help`` and a misspelt subcommand import
    no command module and no controller."""
    parser = _Parser(prog="mjchar", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"mjchar {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                parser_class=_Parser)
    named = None if argv is None else next((a for a in argv if not a.startswith("-")), "")
    for name, line in COMMANDS.items():
        if named is not None and name != named:
            sub.add_parser(name, help=line)
            continue
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
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    command = "mjchar"
    _printable_paths()
    try:
        argv = sys.argv[1:] if argv is None else list(argv)
        parser = build_parser(argv)
        args, extra = parser.parse_known_args(argv)
        if extra:  # the subcommand's error: `mjchar run: error: unrecognized arguments: ...`
            parser.commands[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
        command = f"mjchar {args.command}"
        try:
            code = int(args.func(args) or 0)
        except MjcharError as e:
            print(f"{command}: error: {one_line(str(e))}", file=sys.stderr)
            return 2
        except MemoryError:
            print(f"{command}: error: out of memory (an input too large for this machine?)",
                  file=sys.stderr)
            return 2
        except BrokenPipeError:
            raise
        except OSError as e:  # a file system refusal outside the project's checks (disk full...)
            where = f": {e.filename}" if e.filename else ""
            print(f"{command}: error: {one_line(e.strerror or str(e))}{where}", file=sys.stderr)
            return 2
        sys.stdout.flush()  # a closed pipe shows here, not at exit
        return code
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_BROKEN_PIPE
    except Terminated:
        print(f"{command}: terminated", file=sys.stderr)
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        print(f"{command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _printable_paths() -> None:
    """Let standard output print any file name given on the command line: a name that is not
    valid text in the locale (undecodable bytes, kept by Python as surrogates) is written back
    as its bytes instead of stopping the command with an encoding error."""
    reconfigure = getattr(sys.stdout, "reconfigure", None)
    if reconfigure is not None:
        try:
            reconfigure(errors="surrogateescape")
        except (ValueError, OSError):  # a stream that cannot change: leave it
            pass


def _quiet_stdout() -> None:
    """Point standard output at the null device: Python flushes it again at exit, which would
    report the closed pipe a second time."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # no file descriptor (captured output): nothing to flush
        pass

