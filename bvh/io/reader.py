"""BVH reading.

The reader accepts what real files contain: any channel order per joint, 0-6 channels on any joint,
End Sites, tabs, CRLF or CR line ends, scientific notation, extra whitespace and blank lines,
zero-length bones and any units or up axis (kept as they are in the file; see
:mod:`mjchar.bvh.rigs.units` to convert). Every malformed input raises
:class:`~mjchar.bvh.errors.BVHError` naming the line (1-based; lines end at ``\\n``, ``\\r\\n`` or
``\\r``) and what was expected; no other exception escapes :func:`load`, :func:`loads` or
:func:`read_channels`.

Numbers follow the plain decimal grammar ``[+-]digits[.digits][(e|E)[+-]digits]`` (``.5`` and
``5.`` included); ``nan``, ``inf`` and values that overflow are rejected. Numbers that cannot
describe a human are rejected too, naming the line (:data:`MAX_OFFSET`, :data:`MAX_FRAME_TIME`,
:data:`MAX_ROTATION`, :data:`MAX_POSITION`): the bounds are generous (a 2 m body in millimetres
has offsets near 500, a root travelling 10 km in millimetres positions of 1e7) but stop the
1e30 that would build a 1e30 m body or a frame time that makes a clip last for ages.
``Frames: 0`` is a skeleton without motion (accepted: the converter builds models from such
files). The frame section is
converted with a vectorised decimal parser whose results are bit-identical to Python's
``float()`` (an exact integer mantissa divided by an exact power of ten is correctly rounded);
anything outside its fast path (exponents, very long numbers, malformed text) goes through a
per-token path that is also the one reporting errors.
"""

from __future__ import annotations

import os
import re
import threading
from math import isfinite

import numpy as np

from mjchar.bvh.errors import BVHError, MjcharError
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import VALID_CHANNELS, Skeleton

__all__ = ["load", "loads", "read_channels"]

_BREAK_RE = re.compile(r"\r\n|\r|\n")
# a line reading MOTION (any case, surrounding blanks): preceded and followed by a break or the ends
_MOTION_RE = re.compile(r"(?<![^\r\n])[^\S\r\n]*MOTION[^\S\r\n]*(?![^\r\n])", re.IGNORECASE)
_NUMBER_RE = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z")
_FRAMES_RE = re.compile(r"\s*Frames\s*:\s*(\S+)\s*\Z", re.IGNORECASE)
_FRAME_TIME_RE = re.compile(r"\s*Frame\s+Time\s*:\s*(\S+)\s*\Z", re.IGNORECASE)
_CHANNEL_BY_LOWER = {c.lower(): c for c in VALID_CHANNELS}
#: largest |OFFSET| component, in file units: 1e5 mm is 100 m, far beyond any body, in any unit
MAX_OFFSET = 1e5
#: largest frame time in seconds (0.1 fps); the smallest is anything above 0
MAX_FRAME_TIME = 10.0
#: largest |rotation channel| in degrees (about 280 turns: unwrapped angles of long clips pass)
MAX_ROTATION = 1e5
#: largest |position channel| in file units (10 km in millimetres)
MAX_POSITION = 1e7
_NUM = r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
_EOL = r"[ \t]*(?:\r\n|\r|\n)"
_HIER_START_RE = re.compile(r"\s*HIERARCHY" + _EOL)
_HIER_ITEM_RE = re.compile(rf"""\s*(?:
    (?P<kw>ROOT|JOINT)[ \t]+(?P<name>[^\s{{}}](?:[^\r\n{{}}]*[^\s{{}}])?){_EOL}
    \s*\{{{_EOL}
    \s*OFFSET[ \t]+(?P<ox>{_NUM})[ \t]+(?P<oy>{_NUM})[ \t]+(?P<oz>{_NUM}){_EOL}
    \s*CHANNELS[ \t]+(?P<n>[0-6])(?P<chans>(?:[ \t]+[A-Za-z]+)*){_EOL}
  | End[ \t]+Site{_EOL}
    \s*\{{{_EOL}
    \s*OFFSET[ \t]+(?P<ex>{_NUM})[ \t]+(?P<ey>{_NUM})[ \t]+(?P<ez>{_NUM}){_EOL}
    \s*\}}{_EOL}
  | (?P<close>\}}){_EOL}
)""", re.VERBOSE)
_MAX_FAST_DIGITS = 15  # integer mantissas below 1e15 < 2**53 are exact in float64
_POW10 = 10.0 ** np.arange(26)  # exact up to 1e22; larger ones only serve rows redone by float()
_POW10_INT = np.array([10**k for k in range(17)], dtype=np.uint64)
_ASCII_ZEROS = np.uint64(0x3030303030303030)
# the vectorised frame parser's view of a byte: digits stay, separators / signs / dots become
# '0', anything else (which sends the text to the per-token path) 'x'
_AS_DIGITS = bytes(c if 48 <= c <= 57 else 48 if c in b" \t\r\n.-+" else 120 for c in range(256))


# -- public API ----------------------------------------------------------------------------------
def load(path: str | os.PathLike) -> Motion:
    """Read a BVH file into a :class:`~mjchar.bvh.io.motion.Motion` (file units and axes kept).

    Rotation channels are degrees; ``A B C`` rotation channels mean the intrinsic product
    ``R_A R_B R_C``; position channels replace the joint's offset. The returned motion remembers
    its channel values (``Motion.source_channels``) so that saving it unedited reproduces them.

    Raises :class:`~mjchar.bvh.errors.BVHError` (with the line number) for any malformed content,
    and for a file that cannot be read.
    """
    path = os.fspath(path)
    return loads(_read_text(path), path=path)


def loads(text: str, path: str | None = None) -> Motion:
    """Parse BVH ``text`` into a :class:`~mjchar.bvh.io.motion.Motion`; ``path`` is only used in
    error messages. See :func:`load`."""
    skeleton, frame_time, values = _parse(text, path)
    try:
        return Motion.from_channels(skeleton, frame_time, values, copy=False)
    except MjcharError as e:  # pragma: no cover - _parse validates everything from_channels checks
        raise BVHError(str(e), line=1, path=path) from None


def read_channels(path: str | os.PathLike) -> tuple[Skeleton, float, np.ndarray]:
    """Low-level read: ``(skeleton, frame_time, values)``.

    ``values`` is the raw ``(F, C)`` float array of channel values in file order (degrees for
    rotations, file units for positions), ``C = skeleton.n_channels``; ``frame_time`` in seconds.
    """
    path = os.fspath(path)
    return _parse(_read_text(path), path)


def _read_text(path: str) -> str:
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError as e:
        raise BVHError(f"cannot read file: {e.strerror or e}", path=path) from None
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def _is_number(tok: str) -> bool:
    return _NUMBER_RE.match(tok) is not None


# -- parsing -------------------------------------------------------------------------------------
def _parse(text: str, path: str | None) -> tuple[Skeleton, float, np.ndarray]:
    try:
        return _parse_unchecked(text, path)
    except BVHError:
        raise
    except Exception as e:  # defensive: keep the promise that only BVHError escapes
        raise BVHError(f"unreadable content ({type(e).__name__}: {e})", line=1, path=path) from None


def _find_motion(text: str) -> re.Match | None:
    """The first line reading 'MOTION' (any case, blanks around), or ``None``."""
    i = text.find("MOTION")  # fast path: the usual spelling, then a check of its line
    m = None
    while i >= 0:
        line_start = max(text.rfind("\n", 0, i), text.rfind("\r", 0, i)) + 1
        m = _MOTION_RE.match(text, line_start)
        if m is not None:
            break
        i = text.find("MOTION", i + 6)
    end = m.start() if m else len(text)
    if "motion" in text[:end].lower():  # another spelling may come first: the general search
        m = _MOTION_RE.search(text)
    return m


def _parse_unchecked(text: str, path: str | None) -> tuple[Skeleton, float, np.ndarray]:
    m = _find_motion(text)
    if m is None:  # no MOTION line: parse the hierarchy to report what is missing where
        lines = _BREAK_RE.split(text)
        if len(lines) > 1 and not lines[-1]:
            lines.pop()  # the text after the final line break is not a line
        _parse_hierarchy(lines, None, path)
        raise BVHError("expected a line reading 'MOTION' after the hierarchy, found the end of "
                       "the file", line=max(len(lines), 1), path=path)
    head = text[:m.start()]  # ends with a line break (or is empty)
    motion_line = head.count("\n") + head.count("\r") - head.count("\r\n") + 1
    skeleton = _hierarchy_fast(head)
    if skeleton is None:
        skeleton = _parse_hierarchy(_BREAK_RE.split(head)[:-1], motion_line, path)
    # 'Frames:' and 'Frame Time:' are the next two non-blank lines
    found: list[tuple[int, str]] = []
    pos, line_no, n_text = m.end(), motion_line, len(text)
    brk = _BREAK_RE.match(text, pos)
    pos = brk.end() if brk else n_text
    while len(found) < 2 and pos < n_text:
        brk = _BREAK_RE.search(text, pos)
        end, nxt = (brk.start(), brk.end()) if brk else (n_text, n_text)
        line_no += 1
        if text[pos:end].strip():
            found.append((line_no, text[pos:end]))
        pos = nxt
    if not found:
        raise BVHError("file ends early: expected 'Frames: N' after 'MOTION'", line=line_no,
                       path=path)
    frames_line = found[0][0]
    n_frames = _parse_frames_line(found[0][1], frames_line, path)
    if len(found) < 2:
        raise BVHError(f"file ends early: expected 'Frame Time: seconds' after 'Frames:' (line "
                       f"{frames_line})", line=line_no, path=path)
    frame_time = _parse_frame_time_line(found[1][1], found[1][0], path)
    values = _parse_frames(text[pos:], found[1][0] + 1, n_frames, frames_line,
                           skeleton.n_channels, path)
    _check_channel_values(skeleton, values, text[pos:], found[1][0] + 1, path)
    return skeleton, frame_time, values


def _check_channel_values(skeleton: Skeleton, values: np.ndarray, body: str, first_line: int,
                          path: str | None) -> None:
    """A :class:`BVHError` naming the first frame value beyond :data:`MAX_ROTATION` degrees
    (rotation channels) or :data:`MAX_POSITION` file units (position channels), in file order.
    ``body`` is the frame text, ``first_line`` its first line's number."""
    if values.size == 0:
        return
    limits = np.array([MAX_ROTATION if c.endswith("rotation") else MAX_POSITION
                       for chans in skeleton.channels for c in chans])
    if bool(np.all(values.max(axis=0) <= limits)) and bool(np.all(values.min(axis=0) >= -limits)):
        return
    row, col = np.argwhere(np.abs(values) > limits)[0]
    joint = int(np.searchsorted(skeleton.channel_starts(), col, side="right")) - 1
    channel = skeleton.channels[joint][col - int(skeleton.channel_starts()[joint])]
    rotation = channel.endswith("rotation")
    what = (f"degrees (expected within +-{MAX_ROTATION:g})" if rotation
            else f"file units (expected within +-{MAX_POSITION:g}, 10 km in millimetres)")
    lines = _BREAK_RE.split(body)
    frame_lines = [first_line + i for i, ln in enumerate(lines) if ln.strip()]
    raise BVHError(f"value {col + 1} of frame {row + 1} ({channel} of joint "
                   f"{skeleton.names[joint]!r}) is {values[row, col]:g} {what}: it cannot "
                   f"describe a pose", line=frame_lines[row], path=path)


def _parse_frames_line(line: str, line_no: int, path: str | None) -> int:
    m = _FRAMES_RE.match(line)
    if m is None or not m.group(1).isascii() or not m.group(1).isdigit():
        raise BVHError(f"expected 'Frames: N' with N a whole number >= 0, found {line.strip()!r}",
                       line=line_no, path=path)
    return int(m.group(1))


def _parse_frame_time_line(line: str, line_no: int, path: str | None) -> float:
    m = _FRAME_TIME_RE.match(line)
    value = float(m.group(1)) if m and _is_number(m.group(1)) else float("nan")
    if not (np.isfinite(value) and value > 0):
        raise BVHError(f"expected 'Frame Time: T' with T a positive number of seconds, found "
                       f"{line.strip()!r}", line=line_no, path=path)
    if value > MAX_FRAME_TIME:
        raise BVHError(f"Frame Time {m.group(1)} s is not a frame time (expected at most "
                       f"{MAX_FRAME_TIME:g} s between frames)", line=line_no, path=path)
    return value


def _parse_hierarchy(lines: list[str], motion_line: int | None, path: str | None) -> Skeleton:
    """Skeleton from the header lines (everything before the 'MOTION' line), token by token:
    the general parser, and the one reporting every error (see also :func:`_hierarchy_fast`).
    """
    texts: list[str] = []
    tok_lines: list[int] = []
    for i, ln in enumerate(lines, start=1):
        if "{" in ln or "}" in ln:
            ln = ln.replace("{", " { ").replace("}", " } ")
        parts = ln.split()
        texts.extend(parts)
        tok_lines.extend([i] * len(parts))
    n_tok = len(texts)
    # where the header stops: the MOTION line, or the last line of a file that has none
    stop_line = motion_line if motion_line is not None else max(len(lines), 1)
    stop_what = "the 'MOTION' line" if motion_line is not None else "the end of the file"
    pos = 0

    def err(msg: str, k: int | None = None) -> BVHError:
        return BVHError(msg, line=tok_lines[k] if k is not None else stop_line, path=path)

    def take(expected: str) -> int:
        nonlocal pos
        if pos >= n_tok:
            raise err(f"expected {expected}, found {stop_what}")
        pos += 1
        return pos - 1

    def expect(word: str, context: str) -> int:
        k = take(f"{word!r}{context}")
        if texts[k].upper() != word.upper():
            raise err(f"expected {word!r}{context}, found {texts[k]!r}", k)
        return k

    def offset(what: str) -> list[float]:
        nonlocal pos
        kw = expect("OFFSET", f" in {what}")
        out = []
        for _ in range(3):
            if pos >= n_tok:
                raise err(f"OFFSET of {what} needs 3 numbers, found {len(out)} before {stop_what}",
                          kw)
            k = pos
            tok = texts[k]
            if tok_lines[k] != tok_lines[kw]:  # numbers continue on another line: unusual
                if not _is_number(tok):
                    raise err(f"OFFSET of {what} needs 3 numbers, found {len(out)}", kw)
            elif not _is_number(tok):
                raise err(f"expected a number in the OFFSET of {what}, found {tok!r}", k)
            v = float(tok)
            if not isfinite(v):
                raise err(f"expected a finite number in the OFFSET of {what}, found {tok!r}", k)
            if abs(v) > MAX_OFFSET:
                raise err(f"OFFSET of {what}: {tok} cannot be a length on a body (expected "
                          f"within +-{MAX_OFFSET:g} file units, 100 m in millimetres)", k)
            out.append(v)
            pos += 1
        return out

    names: list[str] = []
    name_lines: dict[str, int] = {}
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    es_parents: list[int] = []
    es_offsets: list[list[float]] = []
    open_lines: list[int] = []  # line of the '{' of each open joint
    stack: list[int] = []  # open joints, innermost last

    def joint(kw: int, parent: int) -> None:
        nonlocal pos
        parts = []
        while pos < n_tok and tok_lines[pos] == tok_lines[kw] and texts[pos] != "{":
            parts.append(texts[pos])
            pos += 1
        if not parts:
            raise err(f"expected a joint name after {texts[kw]}", kw)
        name = " ".join(parts)
        if name in name_lines:
            raise err(f"duplicate joint name {name!r} (first defined on line {name_lines[name]})",
                      kw)
        name_lines[name] = tok_lines[kw]
        brace = expect("{", f" after joint name {name!r}")
        off = offset(f"joint {name!r}")
        ck = take(f"'CHANNELS' for joint {name!r}")
        if texts[ck].upper() != "CHANNELS":
            raise err(f"expected 'CHANNELS' for joint {name!r}, found {texts[ck]!r}", ck)
        nk = take("a channel count")
        if not (texts[nk].isascii() and texts[nk].isdigit()):
            raise err(f"expected a channel count (0-6) after CHANNELS, found {texts[nk]!r}", nk)
        n = int(texts[nk])
        if n > 6:
            raise err(f"expected a channel count between 0 and 6, found {n}", nk)
        chans: list[str] = []
        for _ in range(n):
            if pos >= n_tok:
                raise err(f"CHANNELS of joint {name!r} declares {n} channels, found {len(chans)} "
                          f"before {stop_what}", ck)
            c = _CHANNEL_BY_LOWER.get(texts[pos].lower())
            if c is None:
                if tok_lines[pos] != tok_lines[ck]:
                    raise err(f"CHANNELS of joint {name!r} declares {n} channels but lists "
                              f"{len(chans)}", ck)
                raise err(f"expected a channel name ({', '.join(VALID_CHANNELS)}), found "
                          f"{texts[pos]!r}", pos)
            if c in chans:
                raise err(f"channel {c} repeated for joint {name!r}", pos)
            chans.append(c)
            pos += 1
        names.append(name)
        parents.append(parent)
        offsets.append(off)
        channels.append(tuple(chans))
        stack.append(len(names) - 1)
        open_lines.append(tok_lines[brace])

    if not n_tok:
        raise err(f"expected 'HIERARCHY' and a 'ROOT' joint, found {stop_what}")
    k = take("'HIERARCHY'")
    if texts[k].upper() != "HIERARCHY":
        raise err(f"expected 'HIERARCHY' at the start of the file, found {texts[k]!r}", k)
    k = take("'ROOT' after 'HIERARCHY'")
    if texts[k].upper() != "ROOT":
        raise err(f"expected 'ROOT', found {texts[k]!r}", k)
    joint(k, -1)
    while stack:
        j = stack[-1]
        if pos >= n_tok:
            raise err(f"expected 'JOINT', 'End Site' or '}}' closing joint {names[j]!r} (opened "
                      f"on line {open_lines[-1]}), found {stop_what}")
        k = pos
        pos += 1
        word = texts[k].upper()
        if word == "}":
            stack.pop()
            open_lines.pop()
        elif word == "JOINT":
            joint(k, j)
        elif word == "END":
            s = take("'Site' after 'End'")
            if texts[s].upper() != "SITE":
                raise err(f"expected 'Site' after 'End', found {texts[s]!r}", s)
            what = f"the End Site of joint {names[j]!r}"
            expect("{", f" after 'End Site' of joint {names[j]!r}")
            es_offsets.append(offset(what))
            es_parents.append(j)
            expect("}", f" closing {what}")
        else:
            raise err(f"expected 'JOINT', 'End Site' or '}}' in joint {names[j]!r}, found "
                      f"{texts[k]!r}", k)
    if pos < n_tok:
        if texts[pos].upper() == "ROOT":
            raise err("a second ROOT is not supported: expected one skeleton per file", pos)
        raise err(f"unexpected {texts[pos]!r} after the ROOT joint's closing '}}', expected "
                  f"'MOTION'", pos)
    return Skeleton(names, np.array(parents, dtype=int),
                    np.array(offsets, dtype=float).reshape(-1, 3), channels,
                    np.array(es_parents, dtype=int),
                    np.array(es_offsets, dtype=float).reshape(-1, 3))


_CHANNEL_LISTS: dict[str, tuple[str, ...] | None] = {}


def _channel_list(text: str) -> tuple[str, ...] | None:
    """Canonical channel names of a CHANNELS line's name list (memoised), ``None`` if invalid
    or repeated."""
    got = _CHANNEL_LISTS.get(text, False)
    if got is False:
        got = tuple(_CHANNEL_BY_LOWER.get(c.lower(), "") for c in text.split())
        if "" in got or len(set(got)) != len(got):
            got = None
        if len(_CHANNEL_LISTS) < 256:
            _CHANNEL_LISTS[text] = got
    return got


def _hierarchy_fast(head: str) -> Skeleton | None:
    """Fast path for the usual layout: ``ROOT``/``JOINT`` name lines, ``{``, ``OFFSET x y z`` and
    ``CHANNELS n ...`` lines, ``End Site { OFFSET x y z }`` blocks and ``}``, in the usual
    spelling, read with one regular expression per item. ``None`` for anything else, including
    every error, which the token parser then reports."""
    m = _HIER_START_RE.match(head)
    if m is None:
        return None
    pos = m.end()
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    es_parents: list[int] = []
    es_offsets: list[list[float]] = []
    stack: list[int] = []
    item = _HIER_ITEM_RE.match
    root = True
    while True:
        m = item(head, pos)
        if m is None:
            return None
        pos = m.end()
        kw, name, ox, oy, oz, n, chan_text, ex, ey, ez, close = m.groups()
        if kw is not None:
            if (kw == "ROOT") != root:
                return None
            root = False
            off = [float(ox), float(oy), float(oz)]
            chans = _channel_list(chan_text)
            if (chans is None or len(chans) != int(n)
                    or not max(abs(off[0]), abs(off[1]), abs(off[2])) <= MAX_OFFSET):
                return None
            parts = name.split()  # names are whitespace-separated words, joined by one space
            names.append(parts[0] if len(parts) == 1 else " ".join(parts))
            parents.append(stack[-1] if stack else -1)
            offsets.append(off)
            channels.append(chans)
            stack.append(len(names) - 1)
        elif close is not None:
            if not stack:
                return None
            stack.pop()
            if not stack:
                break
        else:
            if not stack:
                return None
            off = [float(ex), float(ey), float(ez)]
            if not max(abs(off[0]), abs(off[1]), abs(off[2])) <= MAX_OFFSET:  # also NaN, inf
                return None
            es_offsets.append(off)
            es_parents.append(stack[-1])
    if head[pos:].strip() or len(set(names)) != len(names):
        return None
    return Skeleton(names, np.array(parents, dtype=int),
                    np.array(offsets, dtype=float).reshape(-1, 3), channels,
                    np.array(es_parents, dtype=int),
                    np.array(es_offsets, dtype=float).reshape(-1, 3))


# -- the frame section ---------------------------------------------------------------------------
def _parse_frames(body: str, first_line: int, n_frames: int, frames_line: int, n_ch: int,
                  path: str | None) -> np.ndarray:
    """``(n_frames, n_ch)`` values from the text after the 'Frame Time' line.

    ``first_line`` is the line number of the body's first line; ``frames_line`` the line of
    'Frames:' (for messages).
    """
    if n_ch > 0 and n_frames > 0:
        values = _fast_frames(body, n_frames, n_ch)
        if values is not None:
            return values
    return _slow_frames(body, first_line, n_frames, frames_line, n_ch, path)


class _Scratch(threading.local):
    """Per-thread work arrays reused from call to call.

    Parsing a clip needs a few temporaries the size of the text; allocating them afresh on
    every call makes the C allocator hand memory back to the system and fault it in again,
    which costs as much as the parsing itself on some machines. Arrays up to
    ``_SCRATCH_MAX_BYTES`` are kept (six of them: a few MB per thread at most); larger ones
    are not.
    """

    def __init__(self) -> None:
        self.arrays: dict[str, np.ndarray] = {}

    def get(self, name: str, n: int, dtype: str | type) -> np.ndarray:
        """A work array of ``n`` elements of ``dtype`` (contents undefined)."""
        a = self.arrays.get(name)
        if a is None or a.dtype != np.dtype(dtype) or a.size < n:
            a = np.empty(n, dtype)
            if a.nbytes <= _SCRATCH_MAX_BYTES:
                self.arrays[name] = a
        return a[:n]


_SCRATCH = _Scratch()
_SCRATCH_MAX_BYTES = 1 << 20


def _swar8(v: np.ndarray) -> np.ndarray:
    """In place: each uint64 of ``v`` holding 8 ASCII digits little-endian (first character =
    most significant digit) becomes their integer value, by the classic multiply-and-shift
    ("SWAR") folding of digit pairs, then quads, then the 8. Returns ``v``."""
    v -= _ASCII_ZEROS
    v &= np.uint64(0x0F0F0F0F0F0F0F0F)
    v *= np.uint64(2561)
    v >>= np.uint64(8)
    v &= np.uint64(0x00FF00FF00FF00FF)
    v *= np.uint64(6553601)
    v >>= np.uint64(16)
    v &= np.uint64(0x0000FFFF0000FFFF)
    v *= np.uint64(42949672960001)
    v >>= np.uint64(32)
    return v


def _fast_frames(body: str, n_frames: int, n_ch: int) -> np.ndarray | None:
    """Vectorised parse of well-formed frame text; ``None`` when anything is unusual or wrong.

    Accepts ASCII text made of space/tab/CR/LF separated tokens of the form
    ``[+-]digits[.digits]`` (at least one digit, at most one dot), ``n_ch`` tokens on each
    non-blank line and ``n_frames`` such lines. Every byte below '0' (separators, signs, dots)
    is read as the digit 0, so the 16 bytes ending at a token's last character form a 16-digit
    integer (two 8-byte words, converted by :func:`_swar8`) whose last ``len(token)`` digits are
    the token with its dot as a 0; dropping that 0 gives the exact integer mantissa, which
    divided by ``10**decimals`` (exact operands) is the correctly rounded value ``float()`` gives.
    """
    try:
        raw = body.encode("ascii")
    except UnicodeEncodeError:
        return None
    # every byte as a digit: separators, signs and dots read as '0', anything else as 'x'
    digits = raw.translate(_AS_DIGITS)
    if b"x" in digits:
        return None  # exponents, nan/inf, other whitespace or garbage: the per-token path decides
    work = _SCRATCH
    b = np.frombuffer(raw, dtype=np.uint8)
    n = len(b)
    # tokens: maximal runs of non-separators, [starts, ends)
    solid = work.get("solid", n + 2, bool)
    solid[0] = solid[-1] = False
    np.greater(b, 32, out=solid[1:-1])
    flags = work.get("flags", n + 1, bool)
    np.not_equal(solid[1:], solid[:-1], out=flags)
    bounds = np.flatnonzero(flags)
    starts, ends = bounds[0::2], bounds[1::2]
    # byte classes, one at a time in the same work array
    is_ = flags[:n]
    n_signs = int(np.count_nonzero(np.equal(b, 45, out=is_)))
    n_signs += int(np.count_nonzero(np.equal(b, 43, out=is_)))
    n_dots = int(np.count_nonzero(np.equal(b, 46, out=is_)))
    dots = np.flatnonzero(is_) if n_dots != len(starts) or n_dots == 0 else None
    # line breaks: LF, CRLF or a lone CR
    breaks = np.flatnonzero(np.equal(b, 13, out=is_))  # CRs
    if not len(breaks):
        breaks = np.flatnonzero(np.equal(b, 10, out=is_))  # LF only
    elif breaks[-1] + 1 < n and int(np.count_nonzero(np.equal(b, 10, out=is_))) == len(breaks) \
            and bool(np.all(b[breaks + 1] == 10)):
        pass  # CRLF only: the CRs mark the breaks
    else:  # mixed, or lone CRs: a CR not followed by LF and every LF
        lone = np.equal(b, 13, out=is_).copy()
        lone[:-1] &= b[1:] != 10
        breaks = np.flatnonzero(lone | (b == 10))
    # tokens per line: only whole, well-formed frames take this path
    per_line = np.diff(np.searchsorted(starts, np.concatenate([breaks, [n]])), prepend=0)
    rows = per_line[per_line > 0]
    if len(rows) != n_frames or np.any(rows != n_ch):
        return None
    n_tok = len(starts)
    lens = np.subtract(ends, starts, out=work.get("lens", n_tok, np.intp))
    first = b[starts]
    neg = first == 45
    signed = neg | (first == 43)
    if int(np.count_nonzero(signed)) != n_signs:
        return None  # a sign that is not a token's first character
    # decimal points: at most one per token. Common case: every token has the same number of
    # decimals (a fixed "%.Nf" writer); then a '.' sits N bytes before each token's end, and if
    # the text holds no other dots, each token holds exactly that one.
    first_dot = raw.find(b".", int(starts[0]), int(ends[0]))
    fixed = -1 if first_dot < 0 else int(ends[0]) - 1 - first_dot
    if not (n_dots == n_tok and fixed >= 0 and bool(np.all(lens > fixed))
            and bool(np.all(b[ends - (1 + fixed)] == 46))):
        fixed = -1
        if dots is None:
            dots = np.flatnonzero(b == 46)
    if fixed >= 0:
        has_dot, all_dots, decimals = True, True, None
    elif n_dots == n_tok and bool(np.all(dots >= starts)) and bool(np.all(dots < ends)):
        has_dot, all_dots, decimals = True, True, ends - 1 - dots
    else:
        owner = np.searchsorted(starts, dots, side="right") - 1
        if len(owner) > 1 and np.any(np.diff(owner) == 0):
            return None
        all_dots = False
        has_dot = np.zeros(n_tok, dtype=bool)
        has_dot[owner] = True
        decimals = np.zeros(n_tok, dtype=np.intp)
        decimals[owner] = ends[owner] - 1 - dots
    # digits per token: at least 1 ('-', '.', '-.' are not numbers), at most 15 for an exact
    # float64 mantissa (longer tokens are redone with float() below)
    lo, hi = int(lens.min()), int(lens.max())
    redo = np.zeros(0, dtype=np.intp)
    if lo <= 2 or hi > _MAX_FAST_DIGITS:
        n_dig = lens - signed - has_dot
        if np.any(n_dig < 1):
            return None
        redo = np.flatnonzero((n_dig > _MAX_FAST_DIGITS) | (lens > 16))
    # the 16 bytes ending at each token's end, as two little-endian words (the few tokens
    # ending in the first 16 bytes have no such window: they are redone with float() too)
    first_full = int(np.searchsorted(ends, 16))
    windows = np.ndarray((max(n - 15, 0),), dtype="V16", buffer=digits, strides=(1,))
    at = np.subtract(ends, 16, out=work.get("at", n_tok, np.intp))
    at[:first_full] = 0
    pairs = windows[at] if n >= 16 else np.zeros(n_tok, dtype="V16")
    halves = _swar8(pairs.view("<u8"))  # digits 1-8, 9-16, 1-8, 9-16 ... of the windows
    whole = np.multiply(halves[0::2], np.uint64(100_000_000), out=work.get("whole", n_tok, "<u8"))
    whole += halves[1::2]
    np.minimum(lens, 16, out=lens)
    whole %= np.take(_POW10_INT, lens, out=halves[0::2])  # the token, its dot read as a 0
    # drop the 0 standing for the dot: (whole - tail) / 10 + tail, tail = the decimals
    # (decimals > 15 only occur in over-long tokens, redone below: clamp to stay in the tables)
    if fixed >= 0:  # fixed decimals: a scalar divisor (much faster)
        tail = np.remainder(whole, _POW10_INT[min(fixed, 16)], out=halves[1::2])
        p10 = _POW10[min(fixed, 16)]
    else:
        decimals = np.minimum(decimals, 16)
        tail = np.remainder(whole, _POW10_INT[decimals], out=halves[1::2])
        p10 = _POW10[decimals]
    mant = whole.copy() if not all_dots else None
    whole -= tail
    whole //= np.uint64(10)
    whole += tail
    if mant is not None:  # tokens without a dot keep their integer
        whole = np.where(has_dot, whole, mant)
    values = np.divide(whole, p10)  # exact integer / exact power of ten: correctly rounded
    sign = np.multiply(neg, -2.0, out=work.get("sign", n_tok, np.float64))
    sign += 1.0
    values *= sign
    for r in range(first_full):
        values[r] = float(raw[starts[r]:ends[r]])
    for r in redo:  # too long for an exact 15-digit mantissa: let Python round it
        values[r] = float(raw[starts[r]:ends[r]])
    if len(redo) and not np.all(np.isfinite(values[redo])):
        return None
    return values.reshape(n_frames, n_ch)


def _slow_frames(body: str, first_line: int, n_frames: int, frames_line: int, n_ch: int,
                 path: str | None) -> np.ndarray:
    """Token by token, in line order; raises BVHError at the first offending line."""
    lines = _BREAK_RE.split(body) if body else []
    if lines and not lines[-1]:
        lines.pop()  # the text after the final line break is not a line
    rows: list[list[float]] = []
    last_line = first_line - 1
    for i, ln in enumerate(lines):
        toks = ln.split()
        if not toks:
            continue
        line_no = first_line + i
        last_line = line_no
        if len(rows) >= n_frames:
            raise BVHError(f"more frame lines than the {n_frames} that 'Frames:' (line "
                           f"{frames_line}) declares", line=line_no, path=path)
        if len(toks) != n_ch:
            raise BVHError(f"expected {n_ch} channel values on this frame line (frame "
                           f"{len(rows) + 1}), found {len(toks)}", line=line_no, path=path)
        row = []
        for c, tok in enumerate(toks, start=1):
            v = float(tok) if _is_number(tok) else None
            if v is None or not np.isfinite(v):
                raise BVHError(f"expected a finite number as value {c} of frame {len(rows) + 1}, "
                               f"found {tok!r}", line=line_no, path=path)
            row.append(v)
        rows.append(row)
    if len(rows) < n_frames and n_ch > 0:
        end_line = first_line + len(lines) - 1 if lines else first_line - 1
        raise BVHError(f"expected {n_frames} frames (as 'Frames:' on line {frames_line} says), "
                       f"found {len(rows)}: the file ends early", line=max(end_line, last_line, 1),
                       path=path)
    if n_ch == 0:  # frames are empty lines: there must be as many as declared
        if len(lines) < n_frames:
            raise BVHError(f"expected {n_frames} (empty) frame lines for a skeleton without "
                           f"channels (as 'Frames:' on line {frames_line} says), found "
                           f"{len(lines)}", line=max(first_line + len(lines) - 1, 1), path=path)
        return np.zeros((n_frames, 0))
    return np.array(rows, dtype=float).reshape(n_frames, n_ch)
