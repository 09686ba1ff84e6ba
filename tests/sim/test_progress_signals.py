"""A progress bar is built whole: SIGINT and SIGTERM are held while tqdm's ``__init__`` runs
(a signal raised inside it left a half-built bar whose ``__del__`` printed an AttributeError
after ``rtsim: terminated``; seen once in CI's ``test_simulate_sigterm_and_kill_leave_nothing``)."""

from __future__ import annotations

import signal
import threading
from types import SimpleNamespace
from typing import Any

import pytest
import tqdm.auto

from rtsim.sim.progress import progress_bar, whole


def _blocked() -> set[int]:
    return set(signal.pthread_sigmask(signal.SIG_BLOCK, []))


def test_signals_are_held_while_the_bar_is_built(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[set[int]] = []
    init = tqdm.auto.tqdm.__init__

    def spy(self: Any, *a: Any, **k: Any) -> None:
        seen.append(_blocked())
        init(self, *a, **k)

    monkeypatch.setattr(tqdm.auto.tqdm, "__init__", spy)
    before = _blocked()
    bar = progress_bar(SimpleNamespace(quiet=True), total=10, desc="t")
    bar.close()
    assert seen and {signal.SIGINT, signal.SIGTERM} <= seen[0]
    assert _blocked() == before  # the mask is given back


def test_a_signal_sent_while_building_arrives_after_it() -> None:
    """SIGTERM sent to this thread from inside ``make`` is delivered once ``make`` has
    returned whole (sent to the thread: a signal sent to the process may be taken by another
    thread, such as pytest-xdist's, that does not hold it; the command line's runs are
    single-threaded)."""
    got: list[str] = []
    previous = signal.signal(signal.SIGTERM, lambda *_: got.append("term"))
    try:

        def make() -> str:
            signal.pthread_kill(threading.get_ident(), signal.SIGTERM)
            got.append("built")
            return "bar"

        assert whole(make) == "bar"
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert got == ["built", "term"]
