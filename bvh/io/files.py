"""Writing output files safely: never over an input, never half-written.

Every file mjchar writes (BVH, MJCF, trajectories, videos, plots, bench reports) goes through
:func:`atomic_path`: the content is written to a temporary file beside the target and moved into
place (``os.replace``, atomic on one file system) only when complete, so a failed or interrupted
write leaves whatever was there before, byte for byte. :func:`check_output` is what the commands
call before any long work: the target is not one of the command's inputs and its folder can be
written.
"""

from __future__ import annotations

import contextlib
import os
import stat
import uuid
from collections.abc import Iterable, Iterator
from pathlib import Path

from mjchar.bvh.errors import MjcharError

__all__ = ["OutputError", "PendingFile", "atomic_path", "write_text", "write_bytes",
           "check_output", "same_file"]


class OutputError(MjcharError):
    """An output path that would overwrite an input, or that cannot be written."""


class PendingFile:
    """A file being written: content goes to :attr:`tmp`, beside :attr:`path` (same folder,
    same suffix); :meth:`commit` moves it into place, :meth:`discard` removes it and leaves
    ``path`` as it was. For writers that live longer than a ``with`` block (a video recorder);
    otherwise use :func:`atomic_path`."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        _check_not_special(self.path, "the output")
        self.tmp = self.path.with_name(
            f".{self.path.stem}.{uuid.uuid4().hex[:12]}.partial{self.path.suffix}")
        # created as a plain open() would create the target (0666 less the umask), exclusively
        os.close(os.open(self.tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))

    def commit(self) -> Path:
        """Move the written content into place (keeping a replaced file's permissions)."""
        if self.path.exists():
            os.chmod(self.tmp, os.stat(self.path).st_mode & 0o7777)
        os.replace(self.tmp, self.path)
        return self.path

    def discard(self) -> None:
        """Remove what was written; the target is untouched."""
        self.tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path beside ``path`` (same folder, same suffix) to write to; when the block
    ends without an exception it replaces ``path``, otherwise it is removed and ``path`` is left
    as it was.

    Example::

        with atomic_path("out.mp4") as tmp:
            write_video(tmp)          # an exception here leaves out.mp4 untouched
    """
    pending = PendingFile(path)
    try:
        yield pending.tmp
        pending.commit()
    except BaseException:
        pending.discard()
        raise


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8, ``\\n`` line ends) to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
    return Path(path)


def write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def _check_not_special(p: Path, flag: str) -> None:
    """Refuse a target that exists and is not a regular file (a device such as ``/dev/null``
    or ``/dev/full``, a pipe, a socket): moving a finished file into place would replace it."""
    try:
        mode = os.stat(p).st_mode
    except OSError:
        return  # missing (or unreadable: the write itself will say so)
    if not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
        raise OutputError(f"{flag} {p} is a device or pipe, not a file: mjchar writes files "
                          f"beside their target and moves them into place; give a file path")


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether two paths name the same file (the same resolved path, or the same file through a
    link when both exist)."""
    pa, pb = Path(a), Path(b)
    if pa.exists() and pb.exists():
        return os.path.samefile(pa, pb)
    return pa.resolve() == pb.resolve()


def check_output(path: str | os.PathLike, *, inputs: Iterable = (), flag: str = "the output",
                 suffixes: tuple[str, ...] = ()) -> Path:
    """One-line :class:`OutputError` unless ``path`` can be written without touching an input.

    Args:
        path: the output file.
        inputs: the command's input files (paths; ``None`` and non-paths are skipped).
        flag: how the command names the output (``-o``, ``--render``) in the message.
        suffixes: accepted file suffixes (lower case, with the dot); empty: any.
    Returns:
        the path.
    """
    p = Path(path)
    if suffixes and p.suffix.lower() not in suffixes:
        raise OutputError(f"{flag} {path}: give a {' or '.join(suffixes)} path")
    for given in inputs:
        if isinstance(given, str | os.PathLike) and same_file(p, given):
            raise OutputError(f"{flag} {path} is an input of this command ({given}); "
                              "refusing to write over it: give another output path")
    folder = p.resolve().parent
    if not folder.is_dir():
        raise OutputError(f"{flag} {path}: folder {folder} does not exist")
    if p.is_dir():
        raise OutputError(f"{flag} {path} is a folder: give a file path")
    _check_not_special(p, flag)
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"{flag} {path}: folder {folder} is not writable")
    if p.exists() and not os.access(p, os.W_OK):
        raise OutputError(f"{flag} {path} exists and is not writable")
    return p
