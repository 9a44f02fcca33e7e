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
:data:`MAX_CLIP_FRAME_TIME`, :data:`MIN_FRAME_TIME`, :data:`MAX_ROTATION`,
:data:`MAX_POSITION`): the bounds are generous
(a 2 m body in millimetres has offsets near 500, a root travelling 10 km in millimetres
positions of 1e7) but stop the 1e30 that would build a 1e30 m body or a frame time that makes
a clip last for ages.
Input that could exhaust the machine is refused up front, in one line: a file over
:data:`MAX_FILE_BYTES`, a hierarchy over :data:`MAX_HEADER_CHARS` characters or
:data:`MAX_JOINTS` joints, a frame line far longer than its channels need, and files of other
formats (FBX, C3D, glTF, archives, binary data: :mod:`mjchar.bvh.io.inputs` says what they are
and what to do). Joint names with control characters (a NUL byte) are refused naming the line.
Frames are read in chunks of whole lines into one preallocated array, so reading takes about
the file's size in memory once, plus the values.
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
from math import isfinite

import numpy as np

from mjchar.bvh.errors import BVHError, MjcharError
from mjchar.bvh.io.fast_frames import fast_frames as _fast_frames
from mjchar.bvh.io.inputs import read_text
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
#: largest frame time in seconds (0.1 fps)
MAX_FRAME_TIME = 10.0
#: smallest frame time in seconds (10 000 fps, beyond any motion capture; a smaller one makes
#: velocities overflow)
MIN_FRAME_TIME = 1e-4
#: largest frame time in seconds of a clip (two frames or more): 4 frames per second, a third of
#: the slowest rate animation is exported at (12 fps, "on twos") and a sixth of film's; a clip
#: whose header says less was written with a wrong frame time (a single pose's frame time does
#: not matter, :data:`MAX_FRAME_TIME` bounds it)
MAX_CLIP_FRAME_TIME = 0.25
#: largest |rotation channel| in degrees (about 280 turns: unwrapped angles of long clips pass)
MAX_ROTATION = 1e5
#: largest |position channel| in file units (10 km in millimetres)
MAX_POSITION = 1e7
#: largest BVH file, in bytes (a 10-minute 120 fps clip of 60 joints is about 60 MB)
MAX_FILE_BYTES = 256 * 2**20
#: longest hierarchy (the text before the 'MOTION' line), in characters (indentation included:
#: a chain 10 000 joints deep, indented one tab per level, is 50 MB)
MAX_HEADER_CHARS = 64 * 2**20
#: most words in a hierarchy (a joint takes about 15; end sites 8)
MAX_HEADER_WORDS = 40 * 10_000
#: a file without a 'MOTION' line is checked for errors in this much of its start only
_HEADER_SCAN_CHARS = 4 * 2**20
#: most joints in a skeleton (rigs with fingers and a face have a few hundred)
MAX_JOINTS = 10_000
#: frame text is parsed in chunks of about this many characters (whole lines): just under 1 MB,
#: so the fast parser's work arrays fit its reused per-thread arrays (a 50 MB clip parses twice
#: as fast as in one piece)
_CHUNK_CHARS = 2**20 - 64
_CONTROL_RE = re.compile(r"[\x00-\x1f\x7f-\x9f]")
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
    return read_text(path, what="BVH file", max_bytes=MAX_FILE_BYTES, expected="BVH",
                     error=lambda reason, line: BVHError(reason, line=line, path=path),
                     latin1=True)


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
    end = min(m.start() if m else len(text), MAX_HEADER_CHARS)
    if "motion" in text[:end].lower():  # another spelling may come first: the general search
        m = _MOTION_RE.search(text)
    return m


def _parse_unchecked(text: str, path: str | None) -> tuple[Skeleton, float, np.ndarray]:
    m = _find_motion(text)
    if m is None or m.start() > MAX_HEADER_CHARS:
        # no MOTION line (soon enough): parse the hierarchy to report what is missing where
        too_long = len(text) > _HEADER_SCAN_CHARS
        lines = _BREAK_RE.split(text[:_HEADER_SCAN_CHARS])
        if too_long or (len(lines) > 1 and not lines[-1]):
            lines.pop()  # the text after the final line break is not a (whole) line
        if too_long:
            _check_header_lines(lines, path)
        else:
            _parse_hierarchy(lines, None, path)
        if m is not None:
            raise BVHError(f"the hierarchy goes on for more than {MAX_HEADER_CHARS // 2**20} MB "
                           f"before its 'MOTION' line: a BVH hierarchy is far shorter (at most "
                           f"{MAX_JOINTS} joints are read)", line=1, path=path)
        n_lines = text.count("\n") + text.count("\r") - text.count("\r\n")
        if text[-1:] not in ("\n", "\r"):
            n_lines += 1
        raise BVHError("expected a line reading 'MOTION' after the hierarchy, found the end of "
                       "the file", line=max(n_lines, 1), path=path)
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
    if n_frames >= 2 and frame_time > MAX_CLIP_FRAME_TIME:
        raise BVHError(f"Frame Time {frame_time:g} s for {n_frames} frames is a clip of "
                       f"{_minutes(n_frames * frame_time)} at {1 / frame_time:g} frames per "
                       f"second, below any capture or export rate (at least "
                       f"{1 / MAX_CLIP_FRAME_TIME:g}): "
                       "the header's frame time is wrong (30 frames per second is Frame Time: "
                       "0.0333333)", line=found[1][0], path=path)
    values = _parse_frames(text, found[1][0] + 1, n_frames, frames_line, skeleton.n_channels,
                           path, start=pos, skeleton=skeleton)
    return skeleton, frame_time, values


def _check_header_lines(lines: list[str], path: str | None) -> None:
    """Parse a hierarchy cut at :data:`_HEADER_SCAN_CHARS` for its first error, if any (an error
    about where the text stops is not one: the text was cut)."""
    try:
        _parse_hierarchy(lines, None, path)
    except BVHError as e:
        if "found the end of the file" not in e.reason:
            raise


def _channel_limits(skeleton: Skeleton) -> np.ndarray:
    """``(C,)`` the largest magnitude of each channel (:data:`MAX_ROTATION` or
    :data:`MAX_POSITION`)."""
    return np.array([MAX_ROTATION if c.endswith("rotation") else MAX_POSITION
                     for chans in skeleton.channels for c in chans])


def _check_channel_values(skeleton: Skeleton, limits: np.ndarray, values: np.ndarray, body: str,
                          first_line: int, path: str | None, row0: int = 0) -> None:
    """A :class:`BVHError` naming the first frame value beyond :data:`MAX_ROTATION` degrees
    (rotation channels) or :data:`MAX_POSITION` file units (position channels), in file order.
    ``values`` are the frames ``row0 ...`` read from ``body``, whose first line is line
    ``first_line``; ``limits`` from :func:`_channel_limits`."""
    if values.size == 0:
        return
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
    raise BVHError(f"value {col + 1} of frame {row0 + row + 1} ({channel} of joint "
                   f"{skeleton.names[joint]!r}) is {values[row, col]:g} {what}: it cannot "
                   f"describe a pose", line=frame_lines[row], path=path)


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.0f} minutes"


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
    if value < MIN_FRAME_TIME:
        raise BVHError(f"Frame Time {m.group(1)} s is not a frame time (expected at least "
                       f"{MIN_FRAME_TIME:g} s, {1 / MIN_FRAME_TIME:,.0f} frames per second)",
                       line=line_no, path=path)
    return value


def _parse_hierarchy(lines: list[str], motion_line: int | None, path: str | None) -> Skeleton:
    """Skeleton from the header lines (everything before the 'MOTION' line), token by token:
    the general parser, and the one reporting every error (see also :func:`_hierarchy_fast`).
    """
    return _HierarchyParser(lines, motion_line, path).parse()


def _header_tokens(lines: list[str], path: str | None) -> tuple[list[str], list[int]]:
    """``(words, lines)``: the header's words (braces are words of their own) and the 1-based
    line of each; refused past :data:`MAX_HEADER_WORDS`."""
    texts: list[str] = []
    tok_lines: list[int] = []
    for i, ln in enumerate(lines, start=1):
        if "{" in ln or "}" in ln:
            ln = ln.replace("{", " { ").replace("}", " } ")
        parts = ln.split()
        texts.extend(parts)
        tok_lines.extend([i] * len(parts))
        if len(texts) > MAX_HEADER_WORDS:
            raise BVHError(f"the hierarchy holds more than {MAX_HEADER_WORDS} words by this "
                           f"line: more than the {MAX_JOINTS} joints read", line=i, path=path)
    return texts, tok_lines


class _HierarchyParser:
    """The token parser of :func:`_parse_hierarchy`: the header's words, a read position, and
    the skeleton's joints and end sites as they are read."""

    def __init__(self, lines: list[str], motion_line: int | None, path: str | None) -> None:
        self.path = path
        self.texts, self.tok_lines = _header_tokens(lines, path)
        self.n_tok = len(self.texts)
        # where the header stops: the MOTION line, or the last line of a file that has none
        self.stop_line = motion_line if motion_line is not None else max(len(lines), 1)
        self.stop_what = ("the 'MOTION' line" if motion_line is not None
                          else "the end of the file")
        self.pos = 0
        self.names: list[str] = []
        self.name_lines: dict[str, int] = {}
        self.parents: list[int] = []
        self.offsets: list[list[float]] = []
        self.channels: list[tuple[str, ...]] = []
        self.es_parents: list[int] = []
        self.es_offsets: list[list[float]] = []
        self.open_lines: list[int] = []  # line of the '{' of each open joint
        self.stack: list[int] = []  # open joints, innermost last

    def parse(self) -> Skeleton:
        """'HIERARCHY', the ROOT joint and everything inside it, nothing after it."""
        texts, err = self.texts, self.err
        if not self.n_tok:
            raise err(f"expected 'HIERARCHY' and a 'ROOT' joint, found {self.stop_what}")
        k = self.take("'HIERARCHY'")
        if texts[k].upper() != "HIERARCHY":
            raise err(f"expected 'HIERARCHY' at the start of the file, found {texts[k]!r}", k)
        k = self.take("'ROOT' after 'HIERARCHY'")
        if texts[k].upper() != "ROOT":
            raise err(f"expected 'ROOT', found {texts[k]!r}", k)
        self.joint(k, -1)
        while self.stack:
            self.item()
        if self.pos < self.n_tok:
            if texts[self.pos].upper() == "ROOT":
                raise err("a second ROOT is not supported: expected one skeleton per file",
                          self.pos)
            raise err(f"unexpected {texts[self.pos]!r} after the ROOT joint's closing '}}', "
                      f"expected 'MOTION'", self.pos)
        return Skeleton(self.names, np.array(self.parents, dtype=int),
                        np.array(self.offsets, dtype=float).reshape(-1, 3), self.channels,
                        np.array(self.es_parents, dtype=int),
                        np.array(self.es_offsets, dtype=float).reshape(-1, 3))

    def item(self) -> None:
        """The next item inside the innermost open joint: its closing '}', a JOINT or an End
        Site."""
        texts, err = self.texts, self.err
        j = self.stack[-1]
        if self.pos >= self.n_tok:
            raise err(f"expected 'JOINT', 'End Site' or '}}' closing joint {self.names[j]!r} "
                      f"(opened on line {self.open_lines[-1]}), found {self.stop_what}")
        k = self.pos
        self.pos += 1
        word = texts[k].upper()
        if word == "}":
            self.stack.pop()
            self.open_lines.pop()
        elif word == "JOINT":
            self.joint(k, j)
        elif word == "END":
            self.end_site(j)
        else:
            raise err(f"expected 'JOINT', 'End Site' or '}}' in joint {self.names[j]!r}, found "
                      f"{texts[k]!r}", k)

    def err(self, msg: str, k: int | None = None) -> BVHError:
        """The error ``msg`` at the line of word ``k`` (or where the header stops)."""
        return BVHError(msg, line=self.tok_lines[k] if k is not None else self.stop_line,
                        path=self.path)

    def take(self, expected: str) -> int:
        """The index of the next word (``expected`` names it when there is none)."""
        if self.pos >= self.n_tok:
            raise self.err(f"expected {expected}, found {self.stop_what}")
        self.pos += 1
        return self.pos - 1

    def expect(self, word: str, context: str) -> int:
        """The index of the next word, which must be ``word`` (any case)."""
        k = self.take(f"{word!r}{context}")
        if self.texts[k].upper() != word.upper():
            raise self.err(f"expected {word!r}{context}, found {self.texts[k]!r}", k)
        return k

    def offset(self, what: str) -> list[float]:
        """'OFFSET' and its 3 finite numbers within :data:`MAX_OFFSET` (of ``what``)."""
        texts, tok_lines, err = self.texts, self.tok_lines, self.err
        kw = self.expect("OFFSET", f" in {what}")
        out = []
        for _ in range(3):
            if self.pos >= self.n_tok:
                raise err(f"OFFSET of {what} needs 3 numbers, found {len(out)} before "
                          f"{self.stop_what}", kw)
            k = self.pos
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
            self.pos += 1
        return out

    def joint(self, kw: int, parent: int) -> None:
        """A ROOT or JOINT (keyword at word ``kw``): its name, '{', OFFSET and CHANNELS; it
        stays open for its children."""
        name = self.joint_name(kw)
        brace = self.expect("{", f" after joint name {name!r}")
        off = self.offset(f"joint {name!r}")
        chans = self.channel_list(name)
        self.names.append(name)
        self.parents.append(parent)
        self.offsets.append(off)
        self.channels.append(chans)
        self.stack.append(len(self.names) - 1)
        self.open_lines.append(self.tok_lines[brace])

    def joint_name(self, kw: int) -> str:
        """The joint's name: the words after its keyword on the same line, up to a '{'
        (printable, not a duplicate, at most :data:`MAX_JOINTS` joints)."""
        texts, tok_lines, err = self.texts, self.tok_lines, self.err
        if len(self.names) >= MAX_JOINTS:
            raise err(f"more than {MAX_JOINTS} joints: far more than a body has (a rig with "
                      f"fingers and a face has a few hundred)", kw)
        parts = []
        while self.pos < self.n_tok and tok_lines[self.pos] == tok_lines[kw] \
                and texts[self.pos] != "{":
            parts.append(texts[self.pos])
            self.pos += 1
        if not parts:
            raise err(f"expected a joint name after {texts[kw]}", kw)
        name = " ".join(parts)
        bad = _CONTROL_RE.search(name)
        if bad:
            raise err(f"joint name {name[:60]!r} holds a control character (U+"
                      f"{ord(bad.group()):04X}): names are printable text; remove it", kw)
        if name in self.name_lines:
            raise err(f"duplicate joint name {name!r} (first defined on line "
                      f"{self.name_lines[name]})", kw)
        self.name_lines[name] = tok_lines[kw]
        return name

    def channel_list(self, name: str) -> tuple[str, ...]:
        """'CHANNELS', a count of 0-6 and that many distinct channel names (of joint
        ``name``)."""
        texts, tok_lines, err = self.texts, self.tok_lines, self.err
        ck = self.take(f"'CHANNELS' for joint {name!r}")
        if texts[ck].upper() != "CHANNELS":
            raise err(f"expected 'CHANNELS' for joint {name!r}, found {texts[ck]!r}", ck)
        nk = self.take("a channel count")
        if not (texts[nk].isascii() and texts[nk].isdigit()):
            raise err(f"expected a channel count (0-6) after CHANNELS, found {texts[nk]!r}", nk)
        n = int(texts[nk])
        if n > 6:
            raise err(f"expected a channel count between 0 and 6, found {n}", nk)
        chans: list[str] = []
        for _ in range(n):
            if self.pos >= self.n_tok:
                raise err(f"CHANNELS of joint {name!r} declares {n} channels, found {len(chans)} "
                          f"before {self.stop_what}", ck)
            c = _CHANNEL_BY_LOWER.get(texts[self.pos].lower())
            if c is None:
                if tok_lines[self.pos] != tok_lines[ck]:
                    raise err(f"CHANNELS of joint {name!r} declares {n} channels but lists "
                              f"{len(chans)}", ck)
                raise err(f"expected a channel name ({', '.join(VALID_CHANNELS)}), found "
                          f"{texts[self.pos]!r}", self.pos)
            if c in chans:
                raise err(f"channel {c} repeated for joint {name!r}", self.pos)
            chans.append(c)
            self.pos += 1
        return tuple(chans)

    def end_site(self, j: int) -> None:
        """'Site' (after 'End'), '{', OFFSET and '}' of an End Site of joint ``j``."""
        s = self.take("'Site' after 'End'")
        if self.texts[s].upper() != "SITE":
            raise self.err(f"expected 'Site' after 'End', found {self.texts[s]!r}", s)
        what = f"the End Site of joint {self.names[j]!r}"
        self.expect("{", f" after 'End Site' of joint {self.names[j]!r}")
        self.es_offsets.append(self.offset(what))
        self.es_parents.append(j)
        self.expect("}", f" closing {what}")


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
            if (kw == "ROOT") != root or len(names) >= MAX_JOINTS:
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
    if (head[pos:].strip() or len(set(names)) != len(names)
            or any(_CONTROL_RE.search(n) for n in names)):
        return None
    return Skeleton(names, np.array(parents, dtype=int),
                    np.array(offsets, dtype=float).reshape(-1, 3), channels,
                    np.array(es_parents, dtype=int),
                    np.array(es_offsets, dtype=float).reshape(-1, 3))


# -- the frame section ---------------------------------------------------------------------------
def _parse_frames(text: str, first_line: int, n_frames: int, frames_line: int, n_ch: int,
                  path: str | None, start: int = 0, skeleton: Skeleton | None = None
                  ) -> np.ndarray:
    """``(n_frames, n_ch)`` values from ``text[start:]``, the text after the 'Frame Time' line.

    ``first_line`` is the line number of that text's first line; ``frames_line`` the line of
    'Frames:' (for messages). The text is read in chunks of whole lines (about
    :data:`_CHUNK_CHARS`) into one preallocated array, so the work arrays stay small whatever
    the file's size; with ``skeleton`` given, values beyond :data:`MAX_ROTATION` or
    :data:`MAX_POSITION` are refused chunk by chunk.
    """
    n_text = len(text)
    if n_ch == 0:  # frames are empty lines: count them
        if n_text - start > _CHUNK_CHARS:
            raise BVHError(f"a skeleton without channels has empty frame lines, found "
                           f"{(n_text - start) // 2**20} MB of frame text", line=first_line,
                           path=path)
        return _slow_frames(text[start:], first_line, n_frames, frames_line, n_ch, path)
    # every value takes at least two characters (a digit and a separator): a bound on the rows
    # that a huge 'Frames:' count cannot push past
    values = np.empty((min(n_frames, (n_text - start) // (2 * n_ch) + 1), n_ch))
    limits = _channel_limits(skeleton) if skeleton is not None else None
    max_line = 64 * n_ch + 4096
    row, line, pos = 0, first_line, start
    while pos < n_text:
        end = _chunk_end(text, pos)
        if end - pos > _CHUNK_CHARS and end - pos > max_line:
            raise BVHError(f"a frame line of {end - pos} characters: far too long for {n_ch} "
                           f"channel values", line=line, path=path)
        chunk = text[pos:end]
        got = _fast_frames(chunk, None, n_ch)
        if got is None or row + len(got) > n_frames:
            got = _slow_frames(chunk, line, n_frames, frames_line, n_ch, path, row0=row,
                               final=False)
        values[row:row + len(got)] = got
        if limits is not None:
            _check_channel_values(skeleton, limits, got, chunk, line, path, row0=row)
        row += len(got)
        line += chunk.count("\n") + chunk.count("\r") - chunk.count("\r\n")
        pos = end
    if row < n_frames:
        last = line - 1 if n_text == start or text[-1] in "\r\n" else line
        raise BVHError(f"expected {n_frames} frames (as 'Frames:' on line {frames_line} says), "
                       f"found {row}: the file ends early", line=max(last, first_line - 1, 1),
                       path=path)
    return values


def _chunk_end(text: str, pos: int) -> int:
    """End (exclusive) of the chunk of whole lines starting at ``pos``: just after the last line
    break within :data:`_CHUNK_CHARS` characters (never between the CR and LF of a CRLF), or the
    end of the first line when that line is longer, or the end of the text."""
    n = len(text)
    if n - pos <= _CHUNK_CHARS:
        return n
    lim = pos + _CHUNK_CHARS
    i = text.rfind("\n", pos, lim)
    if i < 0:
        i = text.rfind("\r", pos, lim - 1)  # a CR with its next character inside the chunk
    if i >= 0:
        return i + 1
    m = _BREAK_RE.search(text, lim - 1)
    return m.end() if m else n


def _slow_frames(body: str, first_line: int, n_frames: int, frames_line: int, n_ch: int,
                 path: str | None, row0: int = 0, final: bool = True) -> np.ndarray:
    """Token by token, in line order; raises BVHError at the first offending line. ``row0``
    frames came before ``body``; ``final``: ``body`` is the rest of the file (fewer frames
    than declared is an error)."""
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
        if row0 + len(rows) >= n_frames:
            raise BVHError(f"more frame lines than the {n_frames} that 'Frames:' (line "
                           f"{frames_line}) declares", line=line_no, path=path)
        if len(toks) != n_ch:
            raise BVHError(f"expected {n_ch} channel values on this frame line (frame "
                           f"{row0 + len(rows) + 1}), found {len(toks)}", line=line_no,
                           path=path)
        row = []
        for c, tok in enumerate(toks, start=1):
            v = float(tok) if _is_number(tok) else None
            if v is None or not np.isfinite(v):
                raise BVHError(f"expected a finite number as value {c} of frame "
                               f"{row0 + len(rows) + 1}, found {tok[:40]!r}", line=line_no,
                               path=path)
            row.append(v)
        rows.append(row)
    if not final and n_ch > 0:
        return np.array(rows, dtype=float).reshape(len(rows), n_ch)
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
