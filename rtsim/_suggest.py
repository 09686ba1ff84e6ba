"""Did-you-mean: the one place that guesses which known name a mistyped one meant.

A guess is made only when it is likely: the word is the start of one known name (``prio`` →
``priority``, ``accel`` → ``accel_max``), or one known name is within a few edits of it
(a letter missing, extra, wrong, or two swapped: ``perod`` → ``period``, ``nmae`` → ``name``;
one edit for words of up to four letters, two up to eight, three beyond). So ``prio`` never
suggests ``period`` (two edits away in a four-letter word).

Imports nothing from rtsim, so every layer may use it.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping

__all__ = ["close_match", "did_you_mean"]


def _edits(a: str, b: str) -> int:
    """Edits (insert, delete, substitute, swap two neighbours) from ``a`` to ``b``."""
    prev2: list[int] = []
    prev = list(range(len(b) + 1))
    for i in range(1, len(a) + 1):
        cur = [i] + [0] * len(b)
        for j in range(1, len(b) + 1):
            cost = 0 if a[i - 1] == b[j - 1] else 1
            cur[j] = min(prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + cost)
            if i > 1 and j > 1 and a[i - 1] == b[j - 2] and a[i - 2] == b[j - 1]:
                cur[j] = min(cur[j], prev2[j - 2] + 1)
        prev2, prev = prev, cur
    return prev[len(b)]


def _allowed(word: str) -> int:
    return 1 if len(word) <= 4 else 2 if len(word) <= 8 else 3


def close_match(word: object, choices: Iterable[object], ratio: float | None = None) -> str | None:
    """The known name ``word`` most likely means, or None.

    ``ratio``: instead of the rule above, `difflib`'s similarity ratio at least this
    (for a stricter test: is a new name a typo of an existing one?).
    """
    if not isinstance(word, str) or not word:
        return None
    names = [str(c) for c in choices if str(c) != word]
    if not names:
        return None
    if ratio is not None:
        close = difflib.get_close_matches(word, names, n=1, cutoff=ratio)
        return close[0] if close else None
    if len(word) >= 3:
        starts = [n for n in names if n.startswith(word)]
        if len(starts) == 1:
            return starts[0]
    best = min(
        names, key=lambda n: (_edits(word, n), -difflib.SequenceMatcher(None, word, n).ratio())
    )
    return best if _edits(word, best) <= _allowed(word) else None


def did_you_mean(
    word: object,
    choices: Iterable[object],
    ratio: float | None = None,
    renamed: Mapping[str, str] | None = None,
) -> str:
    """`` (did you mean 'x'?)`` for `close_match`, or ``""``; ``renamed``: old names and
    their new ones (`` ('estimate' was renamed; did you mean 'paper'?)``)."""
    if renamed and isinstance(word, str) and word in renamed:
        return f" ('{word}' was renamed; did you mean '{renamed[word]}'?)"
    close = close_match(word, choices, ratio)
    return f" (did you mean '{close}'?)" if close else ""
