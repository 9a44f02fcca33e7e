"""The documentation and the committed data read as documentation, not as a diary: README.md,
every file under docs/ and every data file under assets/ name no work session (``session 12``),
no tracker issue by number (``issue 14``) and no folder of the machine they were made on
(``/work/...``, ``/root/...``, ``/home/...``, ``/tmp/...``). A reader has none of those; a figure
says how to reproduce it instead (docs pages: the command next to each table).

Text files are read line by line; ``.npz`` archives (the bundled trajectories) by their string
fields; other binary files (plots) by their printable runs of text (PNG text chunks, say)."""

from __future__ import annotations

import re
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

#: files still to be rewritten (paths relative to the project root); empty once they are
PENDING: set[str] = set()

#: what a reader cannot use: a work session, an issue number, a build machine's folder
FORBIDDEN = [
    ("a work session", re.compile(r"\bsessions? #?\d+", re.I)),
    ("an issue number", re.compile(r"\bissues? #?\d+", re.I)),
    ("an absolute path of the build machine", re.compile(r"(?<![\w./~-])/(?:work|root|home|tmp)/")),
]

#: code under assets/ is not data (assets/__init__.py)
_CODE_SUFFIXES = {".py", ".pyc"}


def _committed(folder: str) -> list[str]:
    """The files under ``folder`` as git tracks them (every file there outside a checkout)."""
    try:
        out = subprocess.run(["git", "ls-files", "-z", "--", folder], cwd=ROOT,
                             capture_output=True, check=True, timeout=60).stdout
        files = [f for f in out.decode().split("\0") if f]
    except (OSError, subprocess.SubprocessError):
        files = []
    if not files:  # not a git checkout (an unpacked sdist): every file on disk
        files = [p.relative_to(ROOT).as_posix() for p in sorted((ROOT / folder).rglob("*"))
                 if p.is_file() and "__pycache__" not in p.parts]
    return files


def _checked_files() -> list[str]:
    files = ["README.md", *_committed("docs")]
    files += [f for f in _committed("assets") if Path(f).suffix not in _CODE_SUFFIXES]
    return [f for f in files if (ROOT / f).is_file()]


def _lines(path: Path):
    """``(where, text)`` pairs of a file: its lines, an archive's string fields, or a binary
    file's printable runs."""
    data = path.read_bytes()
    if path.suffix == ".npz":
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
        yield "member names", " ".join(names)
        with np.load(path, allow_pickle=False) as z:
            for key in z.files:
                a = z[key]
                if a.dtype.kind in "US":
                    for i, s in enumerate(a.reshape(-1).tolist()):
                        s = s.decode(errors="replace") if isinstance(s, bytes) else s
                        for n, line in enumerate(s.splitlines() or [s], 1):
                            yield f"field {key!r}" + (f"[{i}]" if a.ndim else "") + \
                                  (f", line {n}" if n > 1 else ""), line
        return
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        for m in re.finditer(rb"[\x20-\x7e]{6,}", data):
            yield f"byte {m.start()}", m.group().decode("ascii")
        return
    for n, line in enumerate(text.splitlines(), 1):
        yield f"line {n}", line


def _problems(files) -> list[str]:
    found = []
    for f in files:
        for where, line in _lines(ROOT / f):
            for what, pattern in FORBIDDEN:
                for m in pattern.finditer(line):
                    found.append(f"{f}, {where}: {what} ({m.group()!r}) in: {line.strip()[:160]}")
    return found


def test_the_checked_files_include_the_docs_and_the_data():
    files = _checked_files()
    assert "README.md" in files
    assert any(f.startswith("docs/") and f.endswith(".md") for f in files)
    assert any(f.startswith("assets/trajectories/") for f in files)
    assert not any(f.endswith(".py") for f in files)


@pytest.mark.parametrize("line, bad", [
    ("measured in session 14, then", True),
    ("Issue 12's bars", True),
    ("scripts in `/work/runs/s14/turn/`", True),
    ("(/root/.cache/x)", True),
    ("written to /tmp/out.json", True),
    ("see ../shared/data/bvh/walk60.bvh", False),
    ("https://example.org/home/page", False),
    ("a sessions-long run; issue-free", False),
    ("docs/tmp/x and assets/trajectories/samcon_walk60.npz", False),
])
def test_the_patterns(line, bad):
    assert any(p.search(line) for _, p in FORBIDDEN) == bad


def test_no_session_issue_or_build_machine_path_in_docs_or_data():
    files = [f for f in _checked_files() if f not in PENDING]
    problems = _problems(files)
    assert not problems, (f"{len(problems)} place(s) a reader cannot follow (write what the code "
                          "does and the command that reproduces a figure instead):\n"
                          + "\n".join(problems))
