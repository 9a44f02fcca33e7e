"""The vectorised parser of well-formed BVH frame text (:func:`fast_frames`).

Bit-identical to Python's ``float()`` on every number it accepts: an exact integer mantissa
divided by an exact power of ten is correctly rounded. Anything outside its fast path
(exponents, very long numbers, malformed text) returns ``None`` and goes through the reader's
per-token path, which is also the one reporting errors (:mod:`mjchar.bvh.io.reader`).
"""

from __future__ import annotations

import threading

import numpy as np

__all__ = ["fast_frames"]

_MAX_FAST_DIGITS = 15  # integer mantissas below 1e15 < 2**53 are exact in float64
_POW10 = 10.0 ** np.arange(26)  # exact up to 1e22; larger ones only serve rows redone by float()
_POW10_INT = np.array([10**k for k in range(17)], dtype=np.uint64)
_ASCII_ZEROS = np.uint64(0x3030303030303030)
# the vectorised frame parser's view of a byte: digits stay, separators / signs / dots become
# '0', anything else (which sends the text to the per-token path) 'x'
_AS_DIGITS = bytes(c if 48 <= c <= 57 else 48 if c in b" \t\r\n.-+" else 120 for c in range(256))


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


def fast_frames(body: str, n_frames: int | None, n_ch: int) -> np.ndarray | None:
    """Vectorised parse of well-formed frame text; ``None`` when anything is unusual or wrong.

    Accepts ASCII text made of space/tab/CR/LF separated tokens of the form
    ``[+-]digits[.digits]`` (at least one digit, at most one dot), ``n_ch`` tokens on each
    non-blank line and ``n_frames`` such lines (any number for ``None``). Every byte below '0'
    (separators, signs, dots) is read as the digit 0, so the 16 bytes ending at a token's last
    character form a 16-digit integer (two 8-byte words, converted by :func:`_swar8`) whose
    last ``len(token)`` digits are the token with its dot as a 0; dropping that 0 gives the
    exact integer mantissa, which divided by ``10**decimals`` (exact operands) is the correctly
    rounded value ``float()`` gives.
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
    starts, ends, flags = _token_bounds(b, work)
    # byte classes, one at a time in the same work array
    is_ = flags[:n]
    n_signs, n_dots, dots = _signs_and_dots(b, is_, len(starts))
    breaks = _line_breaks(b, is_)
    # tokens per line: only whole, well-formed frames take this path
    per_line = np.diff(np.searchsorted(starts, np.concatenate([breaks, [n]])), prepend=0)
    rows = per_line[per_line > 0]
    if (n_frames is not None and len(rows) != n_frames) or np.any(rows != n_ch):
        return None
    n_frames = len(rows)
    if not n_frames:
        return np.zeros((0, n_ch))
    n_tok = len(starts)
    lens = np.subtract(ends, starts, out=work.get("lens", n_tok, np.intp))
    first = b[starts]
    neg = first == 45
    signed = neg | (first == 43)
    if int(np.count_nonzero(signed)) != n_signs:
        return None  # a sign that is not a token's first character
    layout = _dot_layout(raw, b, starts, ends, lens, n_dots, dots)
    if layout is None:
        return None
    redo = _long_tokens(lens, signed, layout[1])
    if redo is None:
        return None
    values = _values(digits, ends, lens, neg, layout, work)
    for r in range(int(np.searchsorted(ends, 16))):  # no 16-byte window: let Python read them
        values[r] = float(raw[starts[r]:ends[r]])
    for r in redo:  # too long for an exact 15-digit mantissa: let Python round it
        values[r] = float(raw[starts[r]:ends[r]])
    if len(redo) and not np.all(np.isfinite(values[redo])):
        return None
    return values.reshape(n_frames, n_ch)


def _token_bounds(b: np.ndarray, work: _Scratch) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(starts, ends, flags)``: the tokens of ``b`` (maximal runs of bytes above the space,
    ``[starts, ends)``) and the ``(n + 1,)`` bool work array they were found with."""
    n = len(b)
    solid = work.get("solid", n + 2, bool)
    solid[0] = solid[-1] = False
    np.greater(b, 32, out=solid[1:-1])
    flags = work.get("flags", n + 1, bool)
    np.not_equal(solid[1:], solid[:-1], out=flags)
    bounds = np.flatnonzero(flags)
    return bounds[0::2], bounds[1::2], flags


def _signs_and_dots(b: np.ndarray, is_: np.ndarray,
                    n_tok: int) -> tuple[int, int, np.ndarray | None]:
    """``(signs, dots, dot positions)`` in ``b`` (the positions only when the dots cannot be
    one per token; ``is_``: an ``(n,)`` bool work array)."""
    n_signs = int(np.count_nonzero(np.equal(b, 45, out=is_)))
    n_signs += int(np.count_nonzero(np.equal(b, 43, out=is_)))
    n_dots = int(np.count_nonzero(np.equal(b, 46, out=is_)))
    dots = np.flatnonzero(is_) if n_dots != n_tok or n_dots == 0 else None
    return n_signs, n_dots, dots


def _line_breaks(b: np.ndarray, is_: np.ndarray) -> np.ndarray:
    """Positions of the line breaks in ``b``: LF, CRLF or a lone CR (``is_``: an ``(n,)``
    bool work array)."""
    n = len(b)
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
    return breaks


def _dot_layout(raw: bytes, b: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                lens: np.ndarray, n_dots: int, dots: np.ndarray | None) -> tuple | None:
    """Where the decimal points are: ``(fixed, has_dot, all_dots, decimals)``, ``fixed`` the
    decimals every token has (a fixed ``"%.Nf"`` writer) or -1, ``has_dot`` per token (or
    ``True``), ``decimals`` per token (``None`` when fixed); ``None`` when a token holds two
    dots."""
    n_tok = len(starts)
    # Common case: every token has the same number of decimals (a fixed "%.Nf" writer); then a
    # '.' sits N bytes before each token's end, and if the text holds no other dots, each token
    # holds exactly that one.
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
    return fixed, has_dot, all_dots, decimals


def _long_tokens(lens: np.ndarray, signed: np.ndarray, has_dot) -> np.ndarray | None:
    """Indices of the tokens with more digits than an exact float64 mantissa holds (redone
    with ``float()``); ``None`` when a token has no digit ('-', '.', '-.' are not numbers)."""
    lo, hi = int(lens.min()), int(lens.max())
    redo = np.zeros(0, dtype=np.intp)
    if lo <= 2 or hi > _MAX_FAST_DIGITS:
        n_dig = lens - signed - has_dot
        if np.any(n_dig < 1):
            return None
        redo = np.flatnonzero((n_dig > _MAX_FAST_DIGITS) | (lens > 16))
    return redo


def _values(digits: bytes, ends: np.ndarray, lens: np.ndarray, neg: np.ndarray, layout: tuple,
            work: _Scratch) -> np.ndarray:
    """``(n_tok,)`` the tokens' values from the 16 digit bytes ending at each token's end
    (``lens`` is clipped to 16 in place); the tokens ending in the first 16 bytes have no such
    window and are left for the caller to redo."""
    fixed, has_dot, all_dots, decimals = layout
    n, n_tok = len(digits), len(ends)
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
    return values
