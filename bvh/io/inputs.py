"""Reading a user's input file safely: bounded in size, its format recognised by its first bytes.

Every text file mjchar reads (BVH clips, roles and gains files) comes through :func:`read_text`:

- a path that is a folder, missing or unreadable is one line naming it;
- a regular file larger than the limit is refused before anything is read (the limit is stated
  in the message); a pipe or device (``/dev/zero``, ``/dev/urandom``) is read only up to the
  limit, so nothing reads for ever; a named pipe with no writer reads as empty instead of
  waiting for one;
- the first bytes are checked against formats users mistake for the expected one (FBX, C3D,
  glTF, archives, compressed files, images, NumPy files, Git LFS pointers...) and the message
  says what the file is and what to do (:func:`sniff`); other binary content (NUL bytes among
  many control bytes) is refused as binary;
- text is UTF-8 (with or without a byte-order mark), UTF-16 or UTF-32 with a byte-order mark;
  anything else is read as Latin-1 when the caller allows it (BVH files from old tools), and is
  refused otherwise.
"""

from __future__ import annotations

import codecs
import os
import stat
from collections.abc import Callable
from typing import Any

__all__ = ["sniff", "read_text", "read_parsed", "HEAD_BYTES"]

#: how many leading bytes :func:`sniff` looks at
HEAD_BYTES = 4096

_BOMS = ((codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
         (codecs.BOM_UTF8, "utf-8-sig"), (codecs.BOM_UTF16_LE, "utf-16"),
         (codecs.BOM_UTF16_BE, "utf-16"))

_EXPORT_BVH = ("export BVH from the program that made it (Blender: import it, then File > Export "
               "> Motion Capture (.bvh); MotionBuilder: File > Motion File Export)")

# (leading bytes, offset, what the file is, what to do); the first match wins
_SIGNATURES: tuple[tuple[bytes, int, str, str], ...] = (
    (b"Kaydara FBX Binary", 0, "an FBX file (binary)", _EXPORT_BVH),
    (b"; FBX ", 0, "an FBX file (ASCII)", _EXPORT_BVH),
    (b"glTF", 0, "a glTF binary file (.glb)", _EXPORT_BVH),
    (b"PK\x03\x04", 0, "a zip archive (or a NumPy .npz file)",
     "unpack it and give the file inside"),
    (b"PK\x05\x06", 0, "an empty zip archive", "give the file itself"),
    (b"\x1f\x8b", 0, "a gzip-compressed file", "decompress it first (gunzip FILE)"),
    (b"BZh", 0, "a bzip2-compressed file", "decompress it first (bunzip2 FILE)"),
    (b"\xfd7zXZ\x00", 0, "an xz-compressed file", "decompress it first (unxz FILE)"),
    (b"7z\xbc\xaf\x27\x1c", 0, "a 7-Zip archive", "unpack it and give the file inside"),
    (b"Rar!", 0, "a RAR archive", "unpack it and give the file inside"),
    (b"\x28\xb5\x2f\xfd", 0, "a zstd-compressed file", "decompress it first (unzstd FILE)"),
    (b"\x93NUMPY", 0, "a NumPy .npy file", "give the file this option expects"),
    (b"\x89PNG", 0, "a PNG image", "give the file this option expects"),
    (b"\xff\xd8\xff", 0, "a JPEG image", "give the file this option expects"),
    (b"ftyp", 4, "a video (MP4/QuickTime)", "give the file this option expects"),
    (b"RIFF", 0, "a RIFF file (AVI or WAV)", "give the file this option expects"),
    (b"%PDF", 0, "a PDF document", "give the file this option expects"),
    (b"\x7fELF", 0, "a program (ELF executable)", "give the file this option expects"),
    (b"SQLite format 3", 0, "an SQLite database", "give the file this option expects"),
    (b"version https://git-lfs.github.com/spec", 0, "a Git LFS pointer, not the file's content",
     "fetch the content first (git lfs pull)"),
)


def _is_c3d(head: bytes) -> bool:
    """C3D: byte 2 is 0x50 and byte 1 points at the parameter block (a small block number)."""
    return len(head) >= 2 and head[1] == 0x50 and 1 <= head[0] <= 32 and head[0] not in b"\t\n\r "


def sniff(head: bytes, expected: str = "BVH") -> str | None:
    """What a file starting with ``head`` is, when it is a format users mistake for
    ``expected`` (``"BVH"``, ``"JSON"``, ``"TOML"``): ``"this is an FBX file (binary), not BVH:
    export BVH from ..."``; ``None`` for anything else (which the caller's parser judges)."""
    for sig, at, what, todo in _SIGNATURES:
        if head[at:at + len(sig)] == sig:
            if expected != "BVH" and todo == _EXPORT_BVH:
                todo = f"give the {expected} file this option expects"
            return f"this is {what}, not {expected}: {todo}"
    if _is_c3d(head):
        return (f"this is a C3D file (marker data), not {expected}: solve it to a skeleton and "
                f"export BVH (Blender with a C3D importer, Vicon Nexus, Qualisys, MotionBuilder)")
    text = head.lstrip(codecs.BOM_UTF8).lstrip().lower()
    if expected != "JSON" and text[:1] in (b"{", b"[") and not _binary(head):  # (random bytes
        # start with a brace one time in 128)
        if b'"asset"' in text or b'"gltf' in text or b'"scenes"' in text:
            return f"this is a glTF file, not {expected}: {_EXPORT_BVH}"
        if expected == "BVH":
            return "this is a JSON file, not BVH: give a .bvh motion-capture file"
    if expected != "XML" and (text.startswith(b"<?xml") or text.startswith(b"<mujoco")
                              or text.startswith(b"<collada")):
        what = "a MuJoCo model (MJCF)" if b"<mujoco" in text else "an XML file"
        if b"<collada" in text:
            what = "a COLLADA file (.dae)"
            return f"this is {what}, not {expected}: {_EXPORT_BVH}"
        return f"this is {what}, not {expected}: give it to --model, or give a {expected} file"
    if text.startswith(b"<!doctype html") or text.startswith(b"<html"):
        return (f"this is a web page, not {expected}: a download saved the page instead of the "
                f"file; download the raw file")
    if expected == "BVH" and (text.startswith(b":fully-specified") or text.startswith(b"# ast")
                              or text.startswith(b":version") or text.startswith(b"# amc")):
        return ("this is an Acclaim ASF/AMC file (the CMU database's own format), not BVH: use "
                "the CMU BVH conversion of the clip, or convert ASF/AMC to BVH (e.g. in "
                "Blender with an ASF/AMC importer)")
    return None


_CONTROL_BYTES = bytes(c for c in range(32) if c not in b"\t\n\r\x0b\x0c") + b"\x7f"


def _binary(head: bytes) -> bool:
    """Whether leading bytes are binary data rather than text: NUL bytes among more than 1 %
    control bytes, or a NUL at the very start (a stray NUL in a text file is left to the
    parser, which names its line and what it is in)."""
    if b"\x00" not in head:
        return False
    controls = len(head) - len(head.translate(None, _CONTROL_BYTES))
    return head[:1] == b"\x00" or controls > 0.01 * len(head)


def _bom_encoding(head: bytes) -> str | None:
    for bom, enc in _BOMS:
        if head.startswith(bom):
            return enc
    return None


def read_text(path: str | os.PathLike, *, what: str, max_bytes: int,
              error: Callable[[str, int | None], Exception], expected: str,
              latin1: bool = False) -> str:
    """The text of the file at ``path``, checked as the module docstring says.

    Args:
        path: the file.
        what: how messages name it (``"BVH file"``, ``"roles file"``).
        max_bytes: the largest accepted size in bytes.
        error: makes the exception raised from a one-line reason (which does not name the
            file: ``error`` adds it) and the 1-based line it concerns (``None``: none does).
        expected: the format expected, for :func:`sniff` (``"BVH"``, ``"JSON"``, ``"TOML"``).
        latin1: read text that is not UTF-8 as Latin-1 instead of refusing it.
    Returns:
        the decoded text (a byte-order mark removed).
    """
    path = os.fspath(path)
    limit = f"the {_size(max_bytes)} limit for a {what}"
    try:
        with _open(path) as fh:
            st = os.fstat(fh.fileno())
            if stat.S_ISDIR(st.st_mode):
                raise IsADirectoryError(21, "Is a directory")
            if stat.S_ISREG(st.st_mode) and st.st_size > max_bytes:
                raise error(f"the file is {_size(st.st_size)}, more than {limit}: is it the "
                            f"right file?", None)
            head = fh.read(HEAD_BYTES)
            found = sniff(head, expected)
            if found is not None:
                raise error(found, 1)
            encoding = _bom_encoding(head)
            nul = head.find(b"\x00") if encoding is None and _binary(head) else -1
            if nul >= 0:
                before = head[:nul]
                line = before.count(b"\n") + before.count(b"\r") - before.count(b"\r\n") + 1
                raise error(f"this is binary data, not {expected} text (a NUL byte at byte "
                            f"{nul}): is it the right file?", line)
            if stat.S_ISREG(st.st_mode):  # read into one buffer of the file's size
                raw = bytearray(max(st.st_size, len(head)))
                raw[:len(head)] = head
                got = len(head) + fh.readinto(memoryview(raw)[len(head):])
                del raw[got:]  # a file that shrank meanwhile
            else:
                raw = head + fh.read(max_bytes + 1 - len(head))
    except OSError as e:
        raise error(f"cannot read the {what}: {e.strerror or e}", None) from None
    if not raw and stat.S_ISFIFO(st.st_mode):
        raise error("a named pipe with nothing writing to it: nothing to read", None)
    if len(raw) > max_bytes:  # a pipe or a device: no size to check beforehand
        raise error(f"the input goes on past {limit} (a device or an endless stream?)", None)
    if encoding is not None:
        try:
            return raw.decode(encoding)
        except UnicodeDecodeError as e:
            name = encoding.upper().replace("-SIG", "")
            raise error(f"the file starts with a {name} byte-order mark but is not valid {name} "
                        f"(byte {e.start}): save it as UTF-8", 1) from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        if latin1:
            return raw.decode("latin-1")
        before = raw[:e.start]
        line = before.count(b"\n") + before.count(b"\r") - before.count(b"\r\n") + 1
        raise error(f"not UTF-8 text (byte {e.start}: binary, or another encoding): save it as "
                    f"UTF-8 {expected}", line) from None


def read_parsed(path: str | os.PathLike, *, what: str, max_bytes: int, expected: str,
                parse: Callable[[str], Any], invalid: type[Exception],
                error: Callable[[str], Exception], example: str, invalid_hint: str = "") -> Any:
    """``parse`` of the text of a settings file (roles, gains) read by :func:`read_text`; every
    failure is one line naming the file.

    Args:
        path, what, max_bytes, expected: as :func:`read_text` takes them.
        parse: turns the text into data (``json.loads``, ``tomllib.loads``).
        invalid: the exception ``parse`` raises for text that is not ``expected``.
        error: makes the exception raised from its message.
        example: what the file should hold, for a file nested too deeply to parse.
        invalid_hint: said after the parser's reason for text that is not ``expected``.
    """
    path = os.fspath(path)
    text = read_text(path, what=what, max_bytes=max_bytes, expected=expected,
                     error=lambda reason, line: error(f"{what} {path}: {reason}"))
    try:
        return parse(text)
    except invalid as e:
        raise error(f"{what} {path} is not valid {expected}: {e}{invalid_hint}") from None
    except RecursionError:
        raise error(f"{what} {path} nests too deeply: expected {example}") from None


def _open(path: str):
    """``path`` open for reading in binary. A named pipe is opened without waiting for a writer
    (a plain ``open`` would wait for ever for one that never comes): with none, reading it
    gives an empty input at once; with one, it is read as usual."""
    nonblock = getattr(os, "O_NONBLOCK", 0)
    fd = os.open(path, os.O_RDONLY | nonblock | getattr(os, "O_CLOEXEC", 0))
    try:
        if nonblock:
            os.set_blocking(fd, True)  # reads wait for data again; a pipe with no writer: EOF
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def _size(n: int) -> str:
    if n >= 2**30:
        return f"{n / 2**30:.1f} GB"
    if n >= 2**20:
        return f"{n / 2**20:.1f} MB"
    if n >= 2**10:
        return f"{n / 2**10:.1f} KB"
    return f"{n} bytes"
