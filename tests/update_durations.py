"""Record the long tiers' test durations for ``conftest.py``'s longest-first order.

    python -m pytest -m "slow or claims" -n 2 -p xdist --junitxml=result.xml
    python tests/update_durations.py result.xml [more.xml ...]

Writes ``tests/durations.json``: ``{"seconds": {node id: seconds}}`` (tests of the files given
replace their old entries; the others stay).
"""

from __future__ import annotations

import json
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

OUT = Path(__file__).with_name("durations.json")


def node_id(case: ET.Element) -> str:
    """``tests/test_x.py::name[param]`` of a junit ``testcase`` (classname ``tests.test_x``)."""
    return f"{case.get('classname').replace('.', '/')}.py::{case.get('name')}"


def main(paths: list[str]) -> int:
    seconds = json.loads(OUT.read_text())["seconds"] if OUT.is_file() else {}
    for path in paths:
        for case in ET.parse(path).getroot().iter("testcase"):
            if case.find("skipped") is None:
                seconds[node_id(case)] = round(float(case.get("time", 0.0)), 1)
    OUT.write_text(json.dumps({"seconds": dict(sorted(seconds.items()))}, indent=1) + "\n")
    print(f"{OUT}: {len(seconds)} tests")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
