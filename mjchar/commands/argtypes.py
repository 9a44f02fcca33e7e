"""Argument types shared by the ``mjchar`` subcommands: each turns bad text into argparse's
one-line error (exit status 2) naming the option and what was expected."""

from __future__ import annotations

import argparse
import math


def number(what: str):
    """A parser of finite numbers."""
    return _number(what, lambda v: True, "a finite number")


def positive(what: str, high: float | None = None):
    """A parser of finite numbers > 0 (``what`` names the option in errors), at most ``high``
    when given."""
    if high is not None:
        return _number(what, lambda v: 0 < v <= high, f"positive and at most {high:g}")
    return _number(what, lambda v: v > 0, "positive")


def non_negative(what: str):
    """A parser of finite numbers >= 0."""
    return _number(what, lambda v: v >= 0, "zero or positive")


def fraction(what: str):
    """A parser of numbers from 0 to 1."""
    return _number(what, lambda v: 0 <= v <= 1, "in [0, 1]")


def integer(what: str, minimum: int = 0):
    """A parser of whole numbers >= ``minimum``."""
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be an integer, got {text!r}") from None
        if v < minimum:
            raise argparse.ArgumentTypeError(f"{what} must be at least {minimum}, got {text!r}")
        return v

    parse.__name__ = what
    return parse


def _number(what: str, ok, expected: str):
    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be a number, got {text!r}") from None
        if not (math.isfinite(v) and ok(v)):
            raise argparse.ArgumentTypeError(f"{what} must be {expected}, got {text!r}")
        return v

    parse.__name__ = what
    return parse


def add_floor_argument(p: argparse.ArgumentParser, default: str | None = "contact") -> None:
    """``--floor contact|clip|frame``: how the reference clip is placed on the floor
    (``default=None`` lets a command tell whether it was typed)."""
    from mjchar.bvh.reference.reference_motion import FLOOR_MODES

    p.add_argument("--floor", choices=FLOOR_MODES, default=default,
                   help="contact (default, but `run hand_of_god`, whose root force can follow "
                        "the clip as recorded, uses clip): every frame with a supporting foot "
                        "puts its lowest foot point on the floor (mocap stance feet float "
                        "centimetres above it otherwise), frames in flight are interpolated; "
                        "clip: one shift for the whole clip, by its lowest foot point; frame: "
                        "every frame, flight included")


def assignment(what: str):
    """A parser of ``NAME=VALUE``: ``(name, value)``, NAME an identifier or dotted identifiers
    (``timing.step_time``), the value read as JSON (numbers, true, lists, objects) and otherwise
    kept as text (``update=cem``)."""
    import json

    def parse(text: str) -> tuple[str, object]:
        name, sep, raw = text.partition("=")
        name = name.strip()
        if not sep or not all(w.isidentifier() for w in name.split(".")) or not raw.strip():
            raise argparse.ArgumentTypeError(f"{what} must be NAME=VALUE, got {text!r}")
        try:
            value = json.loads(raw)
        except ValueError:
            value = raw.strip()
        return name, value

    parse.__name__ = what
    return parse
