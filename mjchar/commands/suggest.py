""""Did you mean" for a mistyped name: a controller, a scenario, an option, a gait."""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable


def close(word: str, choices: Iterable[str], n: int = 3) -> list[str]:
    """The choices nearest ``word`` (difflib), best first; none when nothing is near."""
    choices = list(dict.fromkeys(choices))
    found = difflib.get_close_matches(word, choices, n=n, cutoff=0.6)
    lower = {c.lower(): c for c in choices}
    if not found and word.lower() in lower:
        found = [lower[word.lower()]]
    return found


def hint(word: str, choices: Iterable[str], prefix: str = "") -> str:
    """``" (did you mean X?)"``, or the empty string when no choice is near."""
    near = close(word, choices)
    return f" (did you mean {' or '.join(prefix + c for c in near)}?)" if near else ""


_INVALID_CHOICE = re.compile(r"invalid choice: '([^']*)' \(choose from (.*)\)$")


def argparse_message(message: str, option_strings: Iterable[str]) -> str:
    """argparse's error message with a suggestion: the nearest choice of an invalid choice,
    the nearest option of an unrecognised one."""
    m = _INVALID_CHOICE.search(message)
    if m:
        choices = re.findall(r"'([^']*)'", m.group(2))
        return message + hint(m.group(1), choices)
    if message.startswith("unrecognized arguments: "):
        options = sorted(o for o in option_strings if o.startswith("--"))
        words = message.removeprefix("unrecognized arguments: ").split()
        hints = [hint(w.split("=")[0], options).strip(" ()") for w in words if w.startswith("-")]
        hints = [h for h in hints if h]
        return message + (f" ({'; '.join(hints)})" if hints else "")
    return message
