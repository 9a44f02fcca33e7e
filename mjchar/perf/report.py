"""What the measurement entry points share besides timing: where the project's docs and the
shared clips are, a line describing the machine, Markdown tables and writing a table into a
marked block of a docs page.

A docs page holds each generated table between two HTML comments, ``<!-- perf:NAME -->`` and
``<!-- /perf:NAME -->`` (:func:`write_block`); an entry point run with ``--write`` rewrites only
that block, through a temporary file beside the page.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import re
import sys
import time
from collections.abc import Iterable, Sequence
from pathlib import Path

from .errors import PerfError
from .timing import load_average

__all__ = ["ROOT", "DOCS", "SHARED_BVH", "machine_line", "markdown_table", "spread",
           "write_block", "publish", "write_json", "shared_clip", "entry_parser"]

#: the project root of a source checkout (holds ``docs/`` and, beside it, ``../shared``)
ROOT = Path(__file__).resolve().parents[2]
#: the docs pages the entry points write into with ``--write``
DOCS = ROOT / "docs"
#: the shared BVH clips (present in a checkout with ``../shared/data``)
SHARED_BVH = ROOT.parent / "shared" / "data" / "bvh"


def shared_clip(name: str) -> Path:
    """``SHARED_BVH / f"{name}.bvh"``; :class:`PerfError` when it is absent."""
    path = SHARED_BVH / f"{name}.bvh"
    if not path.is_file():
        raise PerfError(f"shared clip {path} not found: this measurement needs ../shared/data "
                        f"beside the checkout")
    return path


def entry_parser(name: str, doc: str) -> argparse.ArgumentParser:
    """The argument parser of the entry point ``python -m mjchar.perf.NAME``, described by the
    first line of its module docstring ``doc``."""
    return argparse.ArgumentParser(prog=f"python -m mjchar.perf.{name}",
                                   description=doc.splitlines()[0])


def machine_line(**versions: str) -> str:
    """``"x86_64, 2 cores, Python 3.11.7, MuJoCo 3.x, <name> <version>..., load average 1.2,
    2026-01-01"``: what a measured table was measured on."""
    import mujoco

    parts = [f"{platform.machine()}", f"{os.cpu_count()} cores", f"Python "
             f"{platform.python_version()}", f"MuJoCo {mujoco.__version__}"]
    parts += [f"{k} {v}" for k, v in versions.items()]
    load = load_average()
    if load is not None:
        parts.append(f"load average {load:.2f}")
    parts.append(time.strftime("%Y-%m-%d"))
    return ", ".join(parts)


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    """A Markdown table: a line of the column names ``header``, the separator line and a line
    per row of ``rows`` (its cells as text)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def spread(values: Iterable[float], spec: str) -> str:
    """``"smallest-largest"`` of ``values``, each formatted by ``spec`` (``".0f"``): the spread
    column of a measured table."""
    values = list(values)
    return f"{min(values):{spec}}-{max(values):{spec}}"


def write_block(page: str | os.PathLike, name: str, body: str) -> Path:
    """Replace the block ``<!-- perf:name -->`` ... ``<!-- /perf:name -->`` of the docs page
    ``page`` (e.g. ``DOCS / "envs.md"``) with ``body``; a page without the block gets it
    appended. Written to a temporary file beside the page, then moved into place. Returns the
    page's path."""
    path = Path(page)
    if not path.is_file():
        raise PerfError(f"docs page {path} not found")
    start, end = f"<!-- perf:{name} -->", f"<!-- /perf:{name} -->"
    text = path.read_text()
    block = f"{start}\n{body.rstrip()}\n{end}"
    if start in text and end in text:
        text = re.sub(re.escape(start) + r".*?" + re.escape(end), lambda _: block, text,
                      count=1, flags=re.S)
    else:
        text = text.rstrip() + f"\n\n{block}\n"
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)
    return path


def publish(text: str, page: str, name: str, write: bool, said: str = "updated") -> None:
    """Print the table ``text``; with ``write`` (an entry point's ``--write``) also put it in
    the block ``name`` of the docs page ``DOCS / page`` (:func:`write_block`) and say so on
    stderr: ``said`` and the page's path."""
    print(text)
    if write:
        print(f"{said} {write_block(DOCS / page, name, text)}", file=sys.stderr, flush=True)


def _plain(v):
    """``v`` as strict JSON can hold it: numpy values as Python ones, non-finite numbers as
    ``None``, tuples as lists, other objects (paths) as strings."""
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_plain(x) for x in v]
    if hasattr(v, "tolist"):  # numpy scalars and arrays
        return _plain(v.tolist())
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if v is None or isinstance(v, bool | int | str):
        return v
    return str(v)


def write_json(path: str | os.PathLike, data) -> Path:
    """``data`` as indented JSON (numpy values as plain numbers, non-finite ones as ``null``),
    through a temporary file."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(_plain(data), indent=1))
    os.replace(tmp, path)
    return path
