"""Running a sweep: serially, on local processes or on a Dask cluster; resumable. Each point is
written to ``DIR/points/`` as it finishes (checksummed), the table ``DIR/results.parquet`` is
built from those files only, and ``DIR/manifest.json`` holds the fingerprint a resumed run
must match. The output directory, resuming, dying workers and locking: docs/sweeps.md.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rtsim.errors import RtsimError, SweepError
from rtsim.io.atomic import dumps, write_json, write_table
from rtsim.io.lock import lock_directory
from rtsim.io.manifest import write_manifest
from rtsim.io.outdir import check_resumable
from rtsim.io.work import check_work
from rtsim.notebook import ResultDisplay
from rtsim.sweep.grid import Point, point_input, points
from rtsim.sweep.kinds import KINDS
from rtsim.sweep.point import RESERVED, execute_point, worker_init
from rtsim.sweep.spec import SweepSpec, canonical_json, load_sweep, spec_fingerprint
from rtsim.sweep.table import build_table, encode_metrics

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["run_sweep", "Sweep", "SweepOutcome", "SweepIncomplete"]

Record = dict[str, Any]
#: What a sweep makes in its directory (the lock file aside), and in ``points/``: point
#: files ``<index>-<key>.json`` and the temporary files of their atomic writes.
MADE = {"points", "manifest.json", "results.parquet", "timings.csv"}
POINT_FILE = r"[0-9]{6,}-[0-9a-f]{12}\.json"
POINT_TMP = r"\.[0-9]{6,}-[0-9a-f]{12}\.json\..*\.tmp"


#: How often the pool's loop looks at a held Ctrl-C or SIGTERM (s).
_POLL_S = 0.1
#: How long the interrupt path waits for the workers and the pool's manager thread (s).
STOP_TIMEOUT_S = 5.0
#: Threads of stopped pools that did not end within `STOP_TIMEOUT_S`: the command line
#: leaves with ``os._exit`` after its cleanup rather than wait for them at exit.
STUCK: list[Any] = []


def _hold_signals(held: list[int]) -> dict[int, Any]:
    """In the main thread, record SIGINT and SIGTERM in ``held`` instead of acting on them;
    returns the handlers to put back (empty elsewhere)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return {}

    def hold(signum: int, frame: Any) -> None:
        held.append(signum)

    # (a signal the process ignores, as under nohup, stays ignored)
    return {
        sig: signal.signal(sig, hold)
        for sig in (signal.SIGINT, signal.SIGTERM)
        if signal.getsignal(sig) is not signal.SIG_IGN
    }


def _restore_signals(restore: dict[int, Any]) -> None:
    import signal

    for sig, handler in restore.items():
        signal.signal(sig, handler)
    restore.clear()


def _raise_held(signum: int, restore: dict[int, Any]) -> None:
    """Act on a held signal as its own handler would (SIGTERM: the command line's
    ``Terminated``; Ctrl-C: KeyboardInterrupt), at a point where no lock is held."""
    handler = restore.get(signum)
    if callable(handler):
        handler(signum, None)
    raise KeyboardInterrupt


def _stop_pool(ex: Any, timeout: float = STOP_TIMEOUT_S) -> None:
    """Stop a process pool after an interrupt: terminate its workers and join them (killed
    if they outlive ``timeout``), shut it down without waiting, join its manager thread with
    a timeout. A manager thread that ended is taken off concurrent.futures' exit hook
    (whose wake-up of an ended pool printed ``OSError: [Errno 9] Bad file descriptor``); one
    that did not is kept in `STUCK`."""
    import concurrent.futures.process as cfp

    procs = list((getattr(ex, "_processes", None) or {}).values())
    manager = getattr(ex, "_executor_manager_thread", None)
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.terminate()
    with contextlib.suppress(Exception):
        ex.shutdown(wait=False, cancel_futures=True)
    deadline = time.monotonic() + timeout
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.join(max(0.0, deadline - time.monotonic()))
            if proc.is_alive():
                proc.kill()
                proc.join(1.0)
    if manager is None:
        return
    manager.join(max(0.1, deadline - time.monotonic()))
    if manager.is_alive():
        STUCK.append(manager)
    else:
        cfp._threads_wakeups.pop(manager, None)


class SweepIncomplete(RtsimError):
    """Some points could not be run (a worker died or the cluster was lost); rerun to retry."""


@dataclass(frozen=True, repr=False)
class SweepOutcome(ResultDisplay):
    """What a run did: the results table and how many points it computed, skipped, failed."""

    table: pd.DataFrame
    computed: int
    skipped: int
    failed: int
    out_dir: Path

    def headline(self) -> dict[str, Any]:
        """Points and where the results are (the short ``repr``)."""
        return {
            "points": len(self.table),
            "computed": self.computed,
            "skipped": self.skipped,
            "failed": self.failed,
            "out_dir": str(self.out_dir),
        }

    def summary_frame(self) -> pd.DataFrame:
        """The results table (one row per point)."""
        return self.table


#: Times a point is started on a process pool whose worker then dies, before it is
#: recorded as failed (the second run is alone on a fresh pool, so it is the culprit).
MAX_ATTEMPTS = 2


def grid_size(spec: SweepSpec) -> int:
    """The number of points of ``spec``'s grid, computed without making them."""
    lengths = [len(v) for _, v in spec.grid]
    if spec.combine == "zip":
        return min(lengths, default=0)
    return math.prod(lengths)


def check_workers(workers: Any) -> int | None:
    """``workers`` as an int >= 1 (None: the default); anything else is an InputError."""
    import numbers

    if workers is None:
        return None
    if isinstance(workers, bool) or not isinstance(workers, numbers.Integral):
        raise SweepError(f"workers: must be an integer >= 1, got {workers!r}")
    if int(workers) < 1:
        raise SweepError(f"--workers must be at least 1, got {workers}")
    return int(workers)


def _checksum(rec: Record) -> str:
    """SHA-256 of a point record (without its ``checksum``) as canonical JSON."""
    import hashlib
    import json

    plain = json.loads(dumps({k: v for k, v in rec.items() if k != "checksum"}, indent=None))
    return hashlib.sha256(canonical_json(plain).encode("utf-8")).hexdigest()


def _read_json(path: Path, point: Point | None = None) -> Record | None:
    """A finished point's record, or None when the file is missing, unreadable, of another
    point, or does not match its checksum (edited or corrupt: the point is run again)."""
    import json

    try:
        rec = json.loads(path.read_text("utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(rec, dict) or rec.get("status") not in ("ok", "failed"):
        return None
    if rec.get("checksum") != _checksum(rec):
        return None
    if point is not None and (rec.get("index") != point.index or rec.get("key") != point.key):
        return None
    return {k: v for k, v in rec.items() if k != "checksum"}


def _start_method() -> str:
    """``fork`` on Linux when this process has no other thread (fast: nothing to re-import;
    the workers see the current ``sys.path`` and environment), else ``spawn``.

    Forking a process with threads can deadlock, and macOS forbids it for system libraries.
    """
    import multiprocessing
    import threading

    if (
        sys.platform == "linux"
        and threading.active_count() == 1
        and "fork" in multiprocessing.get_all_start_methods()
    ):
        return "fork"
    return "spawn"


class _Progress:
    """The tqdm bar (points done, failures, time left) on stderr, created only when enabled
    and only when opened: its monitor thread would make forking workers unsafe."""

    def __init__(self, total: int, initial: int, failed: int, enabled: bool):
        self.total, self.initial, self.failed, self.enabled = total, initial, failed, enabled
        self.bar: Any = None

    def open(self) -> None:
        if self.enabled and self.bar is None:
            from tqdm.auto import tqdm

            self.bar = tqdm(
                total=self.total,
                initial=self.initial,
                desc="sweep",
                unit="pt",
                file=sys.stderr,
                dynamic_ncols=True,
            )
            self.bar.set_postfix(failed=self.failed)

    def advance(self, failed: int) -> None:
        self.open()
        if self.bar is not None:
            self.bar.set_postfix(failed=failed, refresh=False)
            self.bar.update(1)

    def write(self, msg: str) -> None:
        if self.bar is not None:
            self.bar.write(msg, file=sys.stderr)
        else:
            print(msg, file=sys.stderr)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


class Sweep:
    """One sweep bound to an output directory (see the module docstring)."""

    def __init__(
        self,
        spec: SweepSpec | str | os.PathLike[str],
        out_dir: str | os.PathLike[str],
        *,
        force: bool = False,
        allow_code: bool | None = None,
    ):
        self.spec = spec if isinstance(spec, SweepSpec) else load_sweep(spec, allow_code=allow_code)
        self.out = Path(out_dir)
        check_work("grid", grid_size(self.spec), f"{self.spec.source}: grid", force=force)
        self.points = points(self.spec)
        clash = [k for k, _ in self.spec.grid if k in RESERVED and k != "seed"]
        if clash:
            raise SweepError(
                f"{self.spec.source}: grid.{clash[0]}: name is reserved for a results column"
            )

    @property
    def points_dir(self) -> Path:
        return self.out / "points"

    # -- the directory -----------------------------------------------------------------
    def check_out(self, clean: bool = False) -> None:
        """Refuse an output directory holding anything a sweep does not make (another
        command's directory, a user's ``results.parquet``, a stranger in ``points/``).
        ``clean=True`` (under the lock) removes the temporary files of atomic writes a
        killed run left (`rtsim.io.outdir.check_resumable`), in ``points/`` too."""
        import re

        check_resumable(self.out, "sweep", MADE, before_manifest={"points"}, clean=clean)
        if self.points_dir.is_dir():
            for f in sorted(self.points_dir.iterdir()):
                if re.fullmatch(POINT_TMP, f.name):
                    if clean:
                        f.unlink(missing_ok=True)
                elif not re.fullmatch(POINT_FILE, f.name):
                    raise SweepError(
                        f"{self.out}: points/ holds {f.name!r}, which the sweep did "
                        "not make; it is left alone — give a new --out"
                    )

    def _prepare(self, restart: bool, argv: Sequence[str] | None) -> None:
        import json
        import re

        self.check_out(clean=True)  # again, under the lock: a killed run's temporary files go

        fp = self.spec.fingerprint()
        manifest = self.out / "manifest.json"
        if manifest.exists() and not restart:
            try:
                old = json.loads(manifest.read_text("utf-8"))["fingerprint"]
            except (OSError, ValueError, KeyError, TypeError) as exc:
                why = (
                    exc.strerror
                    if isinstance(exc, OSError)
                    else ("no fingerprint" if isinstance(exc, KeyError | TypeError) else "not JSON")
                )
                raise SweepError(
                    f"{manifest}: corrupt or unreadable ({why}); use --restart "
                    "to discard the results in this directory, or another --out"
                ) from None
            if old != fp and not self._regrid(manifest):
                raise SweepError(
                    f"{self.out}: holds results of a different sweep than {self.spec.source} "
                    "(the sweep file changed); use --restart to discard them, or another --out"
                )
        elif not restart and self.points_dir.is_dir() and any(self.points_dir.glob("*.json")):
            raise SweepError(
                f"{self.out}: has point files but no manifest.json; use --restart "
                "to discard them, or another --out"
            )
        if restart:  # only what a sweep made (check_out made sure of it)
            if self.points_dir.is_dir():
                for f in self.points_dir.iterdir():
                    if re.fullmatch(POINT_FILE, f.name) or re.fullmatch(POINT_TMP, f.name):
                        f.unlink(missing_ok=True)
            for name in ("results.parquet", "timings.csv", "manifest.json"):
                (self.out / name).unlink(missing_ok=True)
        self.points_dir.mkdir(parents=True, exist_ok=True)
        base = self.spec.base
        write_manifest(
            self.out,
            command="sweep",
            seed=self.spec.seed,
            inputs={"sweep_file": self.spec.source, "base": None if base is None else base.path},
            argv=None if argv is None else list(argv),
            extra={
                "fingerprint": fp,
                "points": len(self.points),
                "sweep_text": self.spec.text,
                "spec": self.spec.resolved(),
            },
        )

    def _regrid(self, manifest: Path) -> bool:
        """Whether the results in ``self.out`` are of this sweep with another grid (more or
        fewer values, the rest equal): then the finished points this grid has are kept,
        renumbered to their place in it, and True; else False (nothing touched)."""
        import json

        try:
            old = json.loads(manifest.read_text("utf-8"))["spec"]
            same = spec_fingerprint(old, grid=False) == self.spec.fingerprint_but_grid()
        except (OSError, ValueError, KeyError, TypeError):
            return False
        if not same:
            return False
        by_key = {}
        for f in self.points_dir.glob("*.json") if self.points_dir.is_dir() else ():
            rec = _read_json(f)
            if rec is not None:
                by_key[rec.get("key")] = (f, rec)
        for p in self.points:
            found = by_key.get(p.key)
            if found is None or found[0].name == p.filename:
                continue
            f, rec = found
            rec = {**rec, "index": p.index}
            rec["checksum"] = _checksum(rec)
            write_json(self.points_dir / p.filename, rec)
            if not any(q.filename == f.name for q in self.points):
                f.unlink(missing_ok=True)
        return True

    def finished(self, retry_failed: bool = False) -> dict[int, Record]:
        """The point records already on disk (failed ones left out with ``retry_failed``)."""
        out = {}
        for p in self.points:
            rec = _read_json(self.points_dir / p.filename, p)
            if rec is not None and not (retry_failed and rec["status"] == "failed"):
                out[p.index] = rec
        return out

    # -- running -------------------------------------------------------------------------
    def run(
        self,
        *,
        workers: int | None = None,
        dask: Any = None,
        progress: bool | None = None,
        restart: bool = False,
        retry_failed: bool = False,
        argv: Sequence[str] | None = None,
    ) -> SweepOutcome:
        """Run the points not yet done, then write the results table and timings.

        ``dask``: a scheduler address or a ``distributed.Client``. ``workers``: local
        processes (default ``os.cpu_count()``; 1 runs in this process). ``progress``: a tqdm
        bar on stderr (None: only when stderr is a terminal). Raises ``KeyboardInterrupt``
        after stopping cleanly (finished points kept),
        [`SweepIncomplete`][rtsim.sweep.engine.SweepIncomplete] when points
        were lost to dead workers.
        """
        nworkers = check_workers(workers)
        self.check_out()
        with lock_directory(self.out, argv):
            return self._run_locked(nworkers, dask, progress, restart, retry_failed, argv)

    def _run_locked(
        self,
        workers: int | None,
        dask: Any,
        progress: bool | None,
        restart: bool,
        retry_failed: bool,
        argv: Sequence[str] | None,
    ) -> SweepOutcome:
        self._prepare(restart, argv)
        done = self.finished(retry_failed)
        pending = [p for p in self.points if p.index not in done]
        if progress is None:
            progress = sys.stderr.isatty()
        failed_before = sum(1 for r in done.values() if r["status"] == "failed")
        bar = _Progress(len(self.points), len(done), failed_before, bool(progress))
        counts = {"computed": 0, "failed": failed_before, "lost": 0}

        def on_result(p: Point, rec: Record | BaseException) -> None:
            if isinstance(rec, BaseException):
                counts["lost"] += 1
                bar.write(f"rtsim: sweep point {p.index} lost: {type(rec).__name__}: {rec}")
                return
            rec = {"index": p.index, "key": p.key, "params": p.params, "seed": p.seed, **rec}
            rec["metrics"], nonfinite = encode_metrics(rec["metrics"])
            if nonfinite:
                rec["nonfinite"] = nonfinite
            rec["checksum"] = _checksum(rec)
            write_json(self.points_dir / p.filename, rec)
            counts["computed"] += 1
            counts["failed"] += rec["status"] == "failed"
            bar.advance(counts["failed"])

        try:
            if pending:
                nworkers = (os.cpu_count() or 1) if workers is None else workers
                if dask is not None:
                    bar.open()
                    self._run_dask(pending, dask, on_result)
                elif nworkers == 1 or len(pending) == 1:
                    bar.open()
                    self._run_serial(pending, on_result)
                else:  # the bar (a tqdm thread) opens once the workers are forked
                    self._run_processes(pending, min(nworkers, len(pending)), on_result, bar.open)
        finally:
            bar.close()
        if counts["lost"]:
            raise SweepIncomplete(
                f"{self.out}: {counts['lost']} points were not run (workers "
                "lost); run the same command again to finish them"
            )
        table = self.write_results()
        return SweepOutcome(table, counts["computed"], len(done), counts["failed"], self.out)

    def _inputs(self, pending: Iterable[Point]) -> Iterable[tuple[Point, Any]]:
        for p in pending:
            yield p, point_input(self.spec, p)

    def _run_serial(self, pending: list[Point], on_result: Callable[..., None]) -> None:
        for p, pin in self._inputs(pending):
            on_result(p, execute_point(pin, self.spec.metrics))

    def _run_processes(
        self,
        pending: list[Point],
        nworkers: int,
        on_result: Callable[..., None],
        started: Callable[[], None],
    ) -> None:
        """Run ``pending`` on a process pool. A dead worker breaks the pool: a fresh one
        takes over, and the points that were running are started again one at a time (each
        alone, so a point that kills its worker again is known: it is recorded as failed
        after `MAX_ATTEMPTS` starts)."""
        import multiprocessing

        warm = KINDS.resolve(self.spec.kind, "sweep.kind").warm
        if warm is not None and pending:  # e.g. the kernels compiled once, not per worker
            warm(point_input(self.spec, pending[0]))
        method = _start_method()
        if method == "fork":
            import pandas  # noqa: F401 - the results table needs it anyway

            KINDS.resolve(self.spec.kind, "sweep.kind").preload()
        ctx = multiprocessing.get_context(method)

        def pool() -> ProcessPoolExecutor:
            return ProcessPoolExecutor(
                max_workers=nworkers,
                initializer=worker_init,
                initargs=(os.getpid(),),
                mp_context=ctx,
            )

        ex = pool()
        todo = iter(self._inputs(pending))
        retry: list[tuple[Point, Any]] = []  # points whose worker died, run alone
        attempts: dict[int, int] = {}
        inflight: dict[Future[Record], tuple[Point, Any]] = {}
        state = {"broken": False}

        def submit(item: tuple[Point, Any]) -> None:
            try:
                fut = ex.submit(execute_point, item[1], self.spec.metrics)
            except BrokenProcessPool:  # a worker died since the last wait
                state["broken"] = True
                retry.append(item)
                return
            attempts[item[0].index] = attempts.get(item[0].index, 0) + 1
            inflight[fut] = item

        def fill() -> None:
            if state["broken"]:
                return
            if retry:
                if not inflight:
                    submit(retry.pop(0))
                return
            while len(inflight) < 2 * nworkers:
                nxt = next(todo, None)
                if nxt is None:
                    return
                submit(nxt)

        def died(p: Point, exc: BaseException) -> Record:
            return {
                "index": p.index,
                "status": "failed",
                "error": f"WorkerDied: the worker process running this point died "
                f"{attempts[p.index]} times ({type(exc).__name__})",
                "metrics": {},
                "timing": {},
            }

        # Ctrl-C and SIGTERM are held while the pool runs and acted on between waits: an
        # exception raised inside concurrent.futures.wait can leave a future's lock held,
        # and the pool's manager thread then waits on it for ever
        held: list[int] = []
        restore = _hold_signals(held)
        try:
            fill()
            started()
            while inflight or retry:
                if held:
                    _raise_held(held[0], restore)
                finished = (
                    wait(inflight, timeout=_POLL_S, return_when=FIRST_COMPLETED)[0]
                    if inflight
                    else set()
                )
                broken = state["broken"]
                for fut in sorted(finished, key=lambda f: inflight[f][0].index):
                    item = inflight.pop(fut)
                    exc = fut.exception()
                    if isinstance(exc, BrokenProcessPool):
                        broken = True
                        if attempts[item[0].index] >= MAX_ATTEMPTS:
                            on_result(item[0], died(item[0], exc))
                        else:
                            retry.append(item)
                    elif exc is not None:
                        on_result(item[0], exc)
                    else:
                        rec = fut.result()
                        if attempts[item[0].index] > 1:  # rerun after its worker died
                            rec["attempts"] = attempts[item[0].index]
                        on_result(item[0], rec)
                if broken:
                    for fut in list(inflight):  # the whole pool is gone: all of them failed
                        item = inflight.pop(fut)
                        if attempts[item[0].index] >= MAX_ATTEMPTS:
                            on_result(item[0], died(item[0], BrokenProcessPool()))
                        else:
                            retry.append(item)
                    retry.sort(key=lambda it: it[0].index)
                    _stop_pool(ex)  # its manager thread joined with a timeout, not for ever
                    ex = pool()
                    state["broken"] = False
                fill()
            if held:
                _raise_held(held[0], restore)
        except BaseException:
            _stop_pool(ex)
            raise
        finally:
            _restore_signals(restore)
        ex.shutdown(wait=True)

    def _run_dask(self, pending: list[Point], dask: Any, on_result: Callable[..., None]) -> None:
        try:
            from distributed import Client, as_completed
        except ImportError:
            raise SweepError("--dask needs the optional extra: pip install 'rtsim[dask]'") from None
        own = isinstance(dask, str)
        if own:
            try:
                client = Client(dask, timeout="20s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise SweepError(f"--dask {dask}: cannot connect to the scheduler: {exc}") from None
        else:
            client = dask
        prefix = f"rtsim-sweep-{self.spec.fingerprint()[:10]}"
        futures = []
        point_of = {}  # each future's point, by the future's key
        try:
            for p, pin in self._inputs(pending):
                fut = client.submit(
                    execute_point, pin, self.spec.metrics, key=f"{prefix}-{p.index}", pure=False
                )
                point_of[fut.key] = p
                futures.append(fut)
            for fut in as_completed(futures):
                p = point_of[fut.key]
                try:
                    rec = fut.result()
                except Exception as exc:  # noqa: BLE001 - a lost worker; the point stays pending
                    rec = exc
                on_result(p, rec)
        except BaseException:
            client.cancel(futures)
            raise
        finally:
            if own:
                client.close()

    # -- results -------------------------------------------------------------------------
    def table(self) -> pd.DataFrame:
        """The results table from the point files (every point must have finished); always
        writable (`rtsim.sweep.table.build_table`)."""
        recs: dict[int, Record] = {}
        for p in self.points:
            rec = _read_json(self.points_dir / p.filename, p)
            if rec is None:
                raise SweepIncomplete(f"{self.out}: point {p.index} has not finished")
            recs[p.index] = rec
        param_cols = [k for k, _ in self.spec.grid if k != "seed"]
        return build_table(self.points, lambda p: recs[p.index], param_cols, self.spec.seed)

    def timings(self) -> pd.DataFrame:
        """Wall-clock and CPU time, host and pid per finished point."""
        import pandas as pd

        rows = []
        for p in self.points:
            rec = _read_json(self.points_dir / p.filename, p)
            if rec is not None:
                t = rec.get("timing", {})
                rows.append(
                    {
                        "index": p.index,
                        "key": p.key,
                        "status": rec["status"],
                        "wall_s": t.get("wall_s"),
                        "cpu_s": t.get("cpu_s"),
                        "host": t.get("host"),
                        "pid": t.get("pid"),
                    }
                )
        return pd.DataFrame(
            rows, columns=["index", "key", "status", "wall_s", "cpu_s", "host", "pid"]
        )

    def write_results(self) -> pd.DataFrame:
        """Write ``results.parquet`` and ``timings.csv``; return the table."""
        df = self.table()
        write_table(self.out / "results.parquet", df)
        write_table(self.out / "timings.csv", self.timings())
        return df


def run_sweep(
    spec: SweepSpec | str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    workers: int | None = None,
    dask: Any = None,
    progress: bool | None = False,
    restart: bool = False,
    retry_failed: bool = False,
    argv: Sequence[str] | None = None,
    force: bool = False,
    allow_code: bool | None = None,
) -> pd.DataFrame:
    """Run (or resume) a sweep into ``out_dir`` and return its results table.

    Failed points are rows with ``status == "failed"``; they do not raise. ``force`` runs a
    grid above the size limit; ``allow_code``: the sweep file and its base may name Python
    code (``package.module:Name``, `rtsim.registry`). See [`Sweep`][rtsim.sweep.engine.Sweep].
    """
    sweep = Sweep(spec, out_dir, force=force, allow_code=allow_code)
    return sweep.run(
        workers=workers,
        dask=dask,
        progress=progress,
        restart=restart,
        retry_failed=retry_failed,
        argv=argv,
    ).table
