"""BVH reading and writing.

The reader accepts what real files contain: any channel order per joint, 0-6 channels on any joint,
End Sites, tabs, CRLF or CR line ends, scientific notation, extra whitespace, zero-length bones and
any units or up axis (kept as they are in the file; see :mod:`bvh.units` to convert). Every
malformed input raises :class:`~bvh.errors.BVHError` naming the line and what was expected; no
other exception escapes :func:`load` or :func:`loads`.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

import numpy as np

from .errors import BVHError, MjcharError
from .motion import Motion
from .skeleton import VALID_CHANNELS, Skeleton

__all__ = ["load", "loads", "save", "dumps", "read_channels"]

_FRAMES_RE = re.compile(r"^\s*Frames\s*:\s*(\S+)\s*$", re.IGNORECASE)
_FRAME_TIME_RE = re.compile(r"^\s*Frame\s+Time\s*:\s*(\S+)\s*$", re.IGNORECASE)


@dataclass
class _Tok:
    text: str
    line: int  # 1-based


def load(path: str | os.PathLike) -> Motion:
    """Read a BVH file into a :class:`~bvh.motion.Motion` (file units and axes kept).

    Raises :class:`~bvh.errors.BVHError` (with the line number) for any malformed content, and
    for a file that cannot be read.
    """
    path = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError as e:
        raise BVHError(f"cannot read file: {e.strerror or e}", path=path) from None
    return loads(_decode(raw), path=path)


def loads(text: str, path: str | None = None) -> Motion:
    """Parse BVH ``text``; ``path`` is only used in error messages. See :func:`load`."""
    skeleton, frame_time, values = _parse(text, path)
    try:
        return Motion.from_channels(skeleton, frame_time, values)
    except MjcharError as e:  # pragma: no cover - _parse validates everything from_channels checks
        raise BVHError(str(e), line=1, path=path) from None


def read_channels(path: str | os.PathLike) -> tuple[Skeleton, float, np.ndarray]:
    """Low-level read: ``(skeleton, frame_time, values)`` with the raw ``(F, C)`` channel values."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError as e:
        raise BVHError(f"cannot read file: {e.strerror or e}", path=path) from None
    return _parse(_decode(raw), path)


def _decode(raw: bytes) -> str:
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def _parse(text: str, path: str | None) -> tuple[Skeleton, float, np.ndarray]:
    lines = text.splitlines()
    motion_line = None
    for i, ln in enumerate(lines):
        if ln.strip().upper() == "MOTION":
            motion_line = i
            break
    if motion_line is None:
        raise BVHError("no MOTION section found (expected a line reading 'MOTION')",
                       line=max(len(lines), 1), path=path)
    try:
        skeleton = _parse_hierarchy(lines[:motion_line], path)
        frame_time, values = _parse_motion(lines, motion_line, skeleton, path)
    except BVHError:
        raise
    except Exception as e:  # defensive: keep the promise that only BVHError escapes
        raise BVHError(f"unreadable content ({type(e).__name__}: {e})", line=motion_line + 1,
                       path=path) from None
    return skeleton, frame_time, values


def _parse_hierarchy(lines: list[str], path: str | None) -> Skeleton:
    toks = [_Tok(t, i + 1) for i, ln in enumerate(lines) for t in ln.replace("{", " { ").replace(
        "}", " } ").split()]
    end_line = max(len(lines), 1)
    pos = 0

    def err(msg: str, tok: _Tok | None = None) -> BVHError:
        return BVHError(msg, line=tok.line if tok else end_line, path=path)

    def next_tok(expected: str) -> _Tok:
        nonlocal pos
        if pos >= len(toks):
            raise err(f"unexpected end of HIERARCHY section, expected {expected}")
        pos += 1
        return toks[pos - 1]

    def number(expected: str) -> float:
        t = next_tok(expected)
        try:
            v = float(t.text)
        except ValueError:
            raise err(f"expected {expected}, found {t.text!r}", t) from None
        if not np.isfinite(v):
            raise err(f"expected a finite {expected}, found {t.text!r}", t)
        return v

    def expect(word: str) -> _Tok:
        t = next_tok(repr(word))
        if t.text.upper() != word.upper():
            raise err(f"expected {word!r}, found {t.text!r}", t)
        return t

    names: list[str] = []
    name_lines: dict[str, int] = {}
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    es_parents: list[int] = []
    es_offsets: list[list[float]] = []

    def parse_joint(kw: _Tok, parent: int) -> None:
        nonlocal pos
        # joint name: the rest of the keyword's line up to '{'
        name_parts = []
        while pos < len(toks) and toks[pos].line == kw.line and toks[pos].text != "{":
            name_parts.append(toks[pos].text)
            pos += 1
        if not name_parts:
            raise err(f"expected a joint name after {kw.text}", kw)
        name = " ".join(name_parts)
        if name in name_lines:
            raise err(f"duplicate joint name {name!r} (first defined on line {name_lines[name]})", kw)
        name_lines[name] = kw.line
        expect("{")
        expect("OFFSET")
        off = [number("an OFFSET number (3 per OFFSET)") for _ in range(3)]
        j = len(names)
        names.append(name)
        parents.append(parent)
        offsets.append(off)
        t = next_tok("'CHANNELS'")
        if t.text.upper() != "CHANNELS":
            raise err(f"expected 'CHANNELS' for joint {name!r}, found {t.text!r}", t)
        nt = next_tok("a channel count")
        try:
            n = int(nt.text)
        except ValueError:
            raise err(f"expected a channel count (0-6), found {nt.text!r}", nt) from None
        if not 0 <= n <= 6:
            raise err(f"expected a channel count between 0 and 6, found {n}", nt)
        chans = []
        for _ in range(n):
            ct = next_tok("a channel name")
            c = _canonical_channel(ct.text)
            if c is None:
                raise err(f"expected a channel name ({', '.join(VALID_CHANNELS)}), found {ct.text!r}", ct)
            if c in chans:
                raise err(f"channel {c} repeated for joint {name!r}", ct)
            chans.append(c)
        channels.append(tuple(chans))
        while True:
            t = next_tok("'JOINT', 'End Site' or '}'")
            word = t.text.upper()
            if word == "}":
                return
            if word == "JOINT":
                parse_joint(t, j)
            elif word == "END":
                s = next_tok("'Site'")
                if s.text.upper() != "SITE":
                    raise err(f"expected 'Site' after 'End', found {s.text!r}", s)
                expect("{")
                expect("OFFSET")
                es_offsets.append([number("an End Site OFFSET number") for _ in range(3)])
                es_parents.append(j)
                expect("}")
            else:
                raise err(f"expected 'JOINT', 'End Site' or '}}' in joint {name!r}, found {t.text!r}", t)

    if not toks:
        raise err("empty HIERARCHY section: expected 'HIERARCHY' and a 'ROOT' joint", None)
    first = next_tok("'HIERARCHY'")
    if first.text.upper() != "HIERARCHY":
        raise err(f"expected 'HIERARCHY' at the start of the file, found {first.text!r}", first)
    root = next_tok("'ROOT'")
    if root.text.upper() != "ROOT":
        raise err(f"expected 'ROOT', found {root.text!r}", root)
    parse_joint(root, -1)
    if pos < len(toks):
        t = toks[pos]
        if t.text.upper() == "ROOT":
            raise err("a second ROOT is not supported: expected one skeleton per file", t)
        raise err(f"unexpected {t.text!r} after the ROOT joint's closing '}}', expected 'MOTION'", t)
    return Skeleton(names, np.array(parents), np.array(offsets), channels,
                    np.array(es_parents, dtype=int), np.array(es_offsets).reshape(-1, 3))


def _canonical_channel(text: str) -> str | None:
    low = text.lower()
    for c in VALID_CHANNELS:
        if c.lower() == low:
            return c
    return None


def _parse_motion(lines: list[str], motion_line: int, skeleton: Skeleton,
                  path: str | None) -> tuple[float, np.ndarray]:
    i = motion_line + 1
    n_lines = len(lines)

    def next_content(expected: str) -> int:
        nonlocal i
        while i < n_lines and not lines[i].strip():
            i += 1
        if i >= n_lines:
            raise BVHError(f"file ends early: expected {expected}", line=n_lines, path=path)
        i += 1
        return i - 1

    k = next_content("'Frames: N'")
    m = _FRAMES_RE.match(lines[k])
    try:
        n_frames = int(m.group(1)) if m else -1
    except ValueError:
        n_frames = -1
    if n_frames < 0:
        raise BVHError(f"expected 'Frames: N' with N a whole number >= 0, found {lines[k].strip()!r}",
                       line=k + 1, path=path)
    k = next_content("'Frame Time: seconds'")
    m = _FRAME_TIME_RE.match(lines[k])
    try:
        frame_time = float(m.group(1)) if m else float("nan")
    except ValueError:
        frame_time = float("nan")
    if not (np.isfinite(frame_time) and frame_time > 0):
        raise BVHError(f"expected 'Frame Time: T' with T a positive number of seconds, found "
                       f"{lines[k].strip()!r}", line=k + 1, path=path)

    n_ch = skeleton.n_channels
    body = lines[i:]
    # fast path: one vectorised conversion of all numbers; slow path only to locate an error
    counts = [len(ln.split()) for ln in body]
    data_rows = [r for r, c in enumerate(counts) if c]
    if len(data_rows) < n_frames:
        last = (i + data_rows[-1] + 1) if data_rows else n_lines
        raise BVHError(f"expected {n_frames} frames (as 'Frames:' says), found {len(data_rows)}",
                       line=max(last, 1), path=path)
    if len(data_rows) > n_frames:
        extra = i + data_rows[n_frames] + 1
        raise BVHError(f"more frame lines than the {n_frames} that 'Frames:' declares", line=extra,
                       path=path)
    for r in data_rows:
        if counts[r] != n_ch:
            raise BVHError(f"expected {n_ch} channel values on this frame line, found {counts[r]}",
                           line=i + r + 1, path=path)
    try:
        values = np.array(" ".join(body[r] for r in data_rows).split(), dtype=float)
        ok = bool(np.all(np.isfinite(values)))
    except ValueError:
        ok = False
    if not ok:
        for r in data_rows:
            for tok in body[r].split():
                try:
                    v = float(tok)
                except ValueError:
                    v = float("nan")
                if not np.isfinite(v):
                    raise BVHError(f"expected a finite number, found {tok!r}", line=i + r + 1,
                                   path=path)
    return frame_time, values.reshape(n_frames, n_ch)


# -- writing -----------------------------------------------------------------------------------
def dumps(motion: Motion, precision: int = 6) -> str:
    """BVH text for ``motion``; rotations become Euler angles in each joint's channel order."""
    sk = motion.skeleton
    out = ["HIERARCHY"]
    children = [[] for _ in range(sk.n_joints)]
    for j in range(1, sk.n_joints):
        children[sk.parents[j]].append(j)
    sites = [[] for _ in range(sk.n_joints)]
    for e, p in enumerate(sk.end_site_parents):
        sites[p].append(e)
    fmt = f"{{:.{precision}f}}"

    def vec(v: np.ndarray) -> str:
        return " ".join(fmt.format(float(x)) for x in v)

    def write_joint(j: int, depth: int) -> None:
        ind = "\t" * depth
        out.append(f"{ind}{'ROOT' if j == 0 else 'JOINT'} {sk.names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}\tOFFSET {vec(sk.offsets[j])}")
        out.append(f"{ind}\tCHANNELS {len(sk.channels[j])}" + "".join(f" {c}" for c in sk.channels[j]))
        for c in children[j]:
            write_joint(c, depth + 1)
        for e in sites[j]:
            out.append(f"{ind}\tEnd Site")
            out.append(f"{ind}\t{{")
            out.append(f"{ind}\t\tOFFSET {vec(sk.end_site_offsets[e])}")
            out.append(f"{ind}\t}}")
        out.append(f"{ind}}}")

    write_joint(0, 0)
    out.append("MOTION")
    out.append(f"Frames: {motion.n_frames}")
    out.append(f"Frame Time: {motion.frame_time:.{max(precision, 8)}g}")
    values = motion.to_channels()
    if values.shape[1]:
        row = " ".join([f"%.{precision}f"] * values.shape[1])
        out.extend(row % tuple(r) for r in values)
    else:
        out.extend("" for _ in range(motion.n_frames))
    return "\n".join(out) + "\n"


def save(motion: Motion, path: str | os.PathLike, precision: int = 6) -> None:
    """Write ``motion`` to ``path`` as BVH (see :func:`dumps`)."""
    with open(os.fspath(path), "w", encoding="utf-8", newline="\n") as fh:
        fh.write(dumps(motion, precision))
