"""How ``mjchar info`` and ``mjchar convert`` describe the joints a conversion leaves out: the
dropped ones counted by kind (``face 71, hand 44, toes 26 joints``), the fused ones by name
(the first few when they are many); ``--json`` lists every name."""

from __future__ import annotations

from collections import Counter

#: fused joints named one by one up to this many
NAMES_SHOWN = 6


def names(items: list[str], shown: int = NAMES_SHOWN) -> str:
    """``a, b, c`` or ``a, b, ... and 12 more``."""
    if len(items) <= shown:
        return ", ".join(items)
    return ", ".join(items[:shown]) + f" and {len(items) - shown} more"


def dropped_lines(converted, qualifier: str = "") -> list[str]:
    """The lines saying what ``converted`` (a conversion result) dropped and fused;
    ``qualifier`` follows the verb (``" by default"``)."""
    fused = list(converted.summary["fused"])
    roles = converted.prepared.rec.joint_roles
    cut = Counter(roles.get(n, "other") for n in converted.info.dropped if n not in fused)
    kinds = ", ".join(f"{k} {v}" for k, v in sorted(cut.items()))
    lines = [f"dropped{qualifier}: " + (f"{kinds} joints" if cut else "none")]
    if fused:
        lines.append(f"fused{qualifier}: {names(fused)}")
    return lines
