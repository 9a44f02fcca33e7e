"""Project exceptions.

Every error mjchar raises on purpose derives from :class:`MjcharError`, so callers can catch the
whole family with one ``except``. Errors about input files carry the file and line number.
"""

from __future__ import annotations


def name_list(names, limit: int = 30) -> str:
    """``names`` joined by commas for a message, at most ``limit`` of them and then how many
    more (a 5,000-joint skeleton's error stays readable)."""
    names = [str(n) for n in names]
    if len(names) <= limit:
        return ", ".join(names)
    return ", ".join(names[:limit]) + f", ... ({len(names) - limit} more)"


class MjcharError(Exception):
    """Base class of every exception mjchar raises on purpose."""


class BVHError(MjcharError):
    """A BVH file (or text) is malformed or cannot be represented.

    Attributes:
        path: file the text came from, or ``None`` for text given directly.
        line: 1-based line number of the offending line, or ``None`` when no line applies.
        reason: what was wrong and what was expected, without the location prefix.
    """

    def __init__(self, reason: str, *, line: int | None = None, path: str | None = None):
        self.reason = reason
        self.line = line
        self.path = path
        where = path or "<bvh text>"
        if line is not None:
            where = f"{where}, line {line}"
        super().__init__(f"{where}: {reason}")


class SkeletonError(MjcharError):
    """A skeleton or motion operation got arguments it cannot work with (unknown joint, shapes)."""


class ReferenceMotionError(MjcharError):
    """A motion cannot be expressed in a model (joint missing, unsupported joint layout, ...)."""


class IKError(MjcharError):
    """An inverse-kinematics problem or option cannot be used (bad target, nothing can move...)."""
