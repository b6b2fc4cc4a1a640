"""``uvnav campaign``: many simulate → replay → assess runs from one spec, on Dask.

Usage::

    uvnav campaign SPEC.toml --out DIR [--workers N] [--scheduler ADDRESS]
                   [--resume | --restart]

The runs of the spec (engine/campaign/spec.py, docs/CAMPAIGN.md) are mapped over a
dask.distributed cluster: by default a ``LocalCluster`` of ``--workers`` single-threaded worker
processes (default: one per core); ``--scheduler tcp://HOST:PORT`` uses a running cluster
(``dask scheduler`` / ``dask worker``). Every input a run needs is shipped with the tasks, so
workers need no shared files. Each finished run is recorded at once (``DIR/parts/``); the table
``DIR/runs.parquet`` is rewritten as runs finish (every 10 s or more), at the end and after
Ctrl-C, with
``DIR/summary.md`` and the plots ``DIR/coverage.svg`` and ``DIR/error_since_fix.svg``.

A second call on the same ``--out`` skips the runs already recorded (``--resume`` insists that
there are some; ``--restart`` removes them and starts again); a changed spec on a used ``--out``
is refused unless ``--restart``. A worker that dies mid-run has its task run again elsewhere
(the scheduler's ``allowed-failures``, 3 by default); a run that raises is a ``failed`` row.

Exit status: 0 every run of the spec is in the table (failed runs included); 2 bad input (spec,
scenarios, data files, arguments, an unreachable scheduler, a changed spec), nothing run; 1 an
output cannot be written; 3 the cluster was lost mid-campaign (the scheduler went away: the
table holds every run finished before it, rerun to finish); 130 interrupted (likewise).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from engine.api import (
    SUMMARY_COLUMNS,
    CampaignSpec,
    CampaignStore,
    InputError,
    RunTask,
    blank_row,
    load_campaign,
    read_table,
    run_one,
    summary_markdown,
)
from uvnav_tui.cli.stdout import unfiltered_stderr

if TYPE_CHECKING:
    from distributed import Client, LocalCluster

PROG = "uvnav campaign"
EXIT_OK = 0
EXIT_CANNOT_WRITE = 1
EXIT_BAD_INPUT = 2
EXIT_LOST_CLUSTER = 3
RETRIES = 2
"""Dask ``retries`` of a task that raises on the worker (the run function returns a row for
every failure of a run, so this covers only the task machinery itself)."""
WINDOW_PER_WORKER = 4
"""Tasks in flight per worker thread: the client and scheduler hold this many, not the whole
campaign (memory bounded whatever the number of runs)."""
TABLE_EVERY_S = 10.0
"""Least seconds between rewrites of ``runs.parquet`` during a campaign; the interval is at
least :data:`TABLE_COST_FACTOR` times the last rewrite's own time, so rewriting costs the client
at most 5 % of its time whatever the table's size."""
TABLE_COST_FACTOR = 20.0
CONNECT_TIMEOUT_S = 10
CRASH_ONCE_ENV = "UVNAV_CAMPAIGN_TEST_CRASH_ONCE"
"""Test hook (tests/campaign): a worker that finds this variable set to a path it can create
exits at once, mid-run, the first time (as a killed worker process would)."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvnav campaign``."""
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    p.add_argument("spec", help="campaign spec (TOML, docs/CAMPAIGN.md)")
    p.add_argument("--out", required=True, help="results directory (runs.parquet, summary.md, "
                   "plots; parts/ records each run as it finishes)")
    p.add_argument("--workers", default=None,
                   help="worker processes of the local cluster (default: one per core)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="use a running Dask scheduler (tcp://HOST:8786) instead of a local "
                   "cluster")
    again = p.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true",
                       help="finish the campaign in --out (the default when one is there; "
                       "refused when none is)")
    again.add_argument("--restart", action="store_true",
                       help="remove the results in --out and run every run again")
    return p


def worker_run(bundle: Any, task: RunTask, tracks_dir: str | None) -> dict[str, Any]:
    """The task a worker executes: :func:`engine.api.run_one` (plus the test hook
    :data:`CRASH_ONCE_ENV`)."""
    marker = os.environ.get(CRASH_ONCE_ENV)
    if marker:
        try:
            fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            pass
        else:
            os.close(fd)
            os._exit(70)
    return run_one(bundle, task, tracks_dir)


def _workers(text: str | None) -> int:
    if text is None:
        return max(1, os.cpu_count() or 1)
    t = text.strip()
    if not (t.isascii() and t.isdigit()) or int(t) < 1 or int(t) > 1024:
        raise InputError("Must be a whole number from 1 to 1024 !", field="--workers", text=text)
    return int(t)


def _connect(scheduler: str | None, n_workers: int) -> tuple[Client, LocalCluster | None]:
    """A Dask client: on ``scheduler`` or on a new local cluster of ``n_workers`` processes
    with one thread each (InputError when the scheduler cannot be reached)."""
    import logging

    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            return Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s",
                          set_as_default=False), None
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"Cannot reach the scheduler ({type(exc).__name__}: {exc}) !",
                             field="--scheduler", text=scheduler) from None
    # No dashboard; the scheduler's own small HTTP server (health routes) on a free loopback
    # port rather than 8787, which a second campaign or another Dask user may hold.
    cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR,
                           scheduler_kwargs={"dashboard": False,
                                             "dashboard_address": "127.0.0.1:0"})
    return Client(cluster, set_as_default=False), cluster


class _Progress:
    """Runs done, failed, runs/s and ETA: a rich bar on a terminal, else a line per 10 %."""

    def __init__(self, total: int, skipped: int) -> None:
        self.total, self.done, self.failed = total, 0, 0
        self.skipped = skipped
        self.t0 = time.perf_counter()
        self._bar: Any = None
        self._task: Any = None
        self._next_line = 0.1
        if sys.stderr.isatty() and total:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
            )

            self._bar = Progress(
                TextColumn("campaign"), BarColumn(), MofNCompleteColumn(),
                TextColumn("runs  failed {task.fields[failed]}  {task.fields[rate]} runs/s"),
                TimeElapsedColumn(), TextColumn("ETA {task.fields[eta]}"),
                console=Console(file=unfiltered_stderr()), transient=True)
            self._bar.start()
            self._task = self._bar.add_task("campaign", total=total, failed=0, rate="–",
                                            eta="–")

    @property
    def rate(self) -> float:
        dt = time.perf_counter() - self.t0
        return self.done / dt if dt > 0 else 0.0

    @property
    def eta(self) -> str:
        """Time left at the mean rate so far (h:mm:ss)."""
        if not self.rate:
            return "–"
        left = int(round((self.total - self.done) / self.rate))
        return f"{left // 3600}:{left // 60 % 60:02d}:{left % 60:02d}"

    def add(self, ok: bool) -> None:
        self.done += 1
        self.failed += not ok
        if self._bar is not None:
            self._bar.update(self._task, completed=self.done, failed=self.failed,
                             rate=f"{self.rate:.2f}", eta=self.eta)
        elif self.total and self.done >= self._next_line * self.total:
            self._next_line = (int(10 * self.done / self.total) + 1) / 10
            print(f"{PROG}: {self.done}/{self.total} runs, {self.failed} failed, "
                  f"{self.rate:.2f} runs/s, ETA {self.eta}", file=sys.stderr, flush=True)

    def stop(self) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None


class LostCluster(Exception):
    """The scheduler went away (or cancelled the tasks) mid-campaign: not a failure of a run,
    so nothing is recorded for the runs in flight; the campaign stops and can be resumed."""


def _cancelled(exc: BaseException) -> bool:
    import asyncio
    import concurrent.futures

    return isinstance(exc, asyncio.CancelledError | concurrent.futures.CancelledError) or (
        type(exc).__name__ in ("CancelledError", "FutureCancelledError"))


def _failed_row(task: RunTask, exc: BaseException) -> dict[str, Any]:
    row = blank_row(task)
    name = type(exc).__name__
    if name == "KilledWorker":
        row["error"] = "the worker process died running it, on every retry (KilledWorker)"
    else:
        row["error"] = f"{name}: {exc}"
    return row


def _run_all(client: Client, spec: CampaignSpec, todo: list[RunTask], store: CampaignStore,
             progress: _Progress, tracks_dir: str | None) -> None:
    """Submit ``todo`` through a bounded window and record each row as it completes."""
    from distributed import as_completed

    nthreads = max(1, sum(client.nthreads().values()))
    bundle = client.scatter(spec.bundle(), broadcast=True, hash=False)
    pending: dict[str, RunTask] = {}
    queue: Iterator[RunTask] = iter(todo)
    ac = as_completed(loop=client.loop)

    def submit_next() -> None:
        task = next(queue, None)
        if task is None:
            return
        f = client.submit(worker_run, bundle, task, tracks_dir, key=f"uvnav-run-{task.key}",
                          pure=False, retries=RETRIES)
        pending[f.key] = task
        ac.add(f)

    for _ in range(WINDOW_PER_WORKER * nthreads):
        submit_next()
    last_table = time.monotonic()
    table_every = TABLE_EVERY_S
    for future in ac:
        task = pending.pop(future.key)
        try:
            row = future.result()
        except Exception as exc:  # the task machinery failed: a failed row all the same
            if _cancelled(exc):
                raise LostCluster(f"{type(exc).__name__}: {exc}") from None
            row = _failed_row(task, exc)
        future.release()
        store.append(row)
        progress.add(row["status"] == "ok")
        submit_next()
        if time.monotonic() - last_table > table_every:
            t0 = time.monotonic()
            store.write_table(spec)
            last_table = time.monotonic()
            table_every = max(TABLE_EVERY_S, TABLE_COST_FACTOR * (last_table - t0))


def write_results(spec: CampaignSpec, store: CampaignStore) -> tuple[int, list[Path]]:
    """Write ``runs.parquet``, ``summary.md`` and the plots; returns the row count and the
    files written."""
    from uvnav_tui.cli.campaign_svg import coverage_svg, error_since_fix_svg

    n = store.write_table(spec)
    cols = read_table(store.table_path, columns=list(SUMMARY_COLUMNS)).to_pydict()
    files = [store.table_path]
    text = summary_markdown(cols, name=spec.name, spec_path=spec.path, planned=len(spec.tasks))
    outputs = [("summary.md", text)]
    if any(s == "ok" for s in cols["status"]):
        outputs += [("coverage.svg", coverage_svg(cols, spec.name)),
                    ("error_since_fix.svg", error_since_fix_svg(cols, spec.name))]
    for name, body in outputs:
        path = store.dir / name
        tmp = path.with_name(f".{name}.tmp")
        tmp.write_text(body, encoding="utf-8")
        os.replace(tmp, path)
        files.append(path)
    return n, files


def run_campaign(argv: list[str]) -> int:
    """Entry point of ``uvnav campaign``; returns the exit status (module docstring)."""
    args = build_parser().parse_args(argv)
    store = CampaignStore(args.out)
    try:
        n_workers = _workers(args.workers)
        if args.scheduler is not None and args.workers is not None:
            raise InputError("Only for the local cluster: the scheduler's workers are those "
                             "started with 'dask worker' !", field="--workers", text=args.workers)
        spec = load_campaign(args.spec)
        store.open(spec, restart=args.restart, resume=args.resume)
        done = store.finished() & {t.key for t in spec.tasks}
        todo = [t for t in spec.tasks if t.key not in done]
        client, cluster = _connect(args.scheduler, n_workers) if todo else (None, None)
    except InputError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:
        print(f"{PROG}: {exc.filename or args.out}: cannot write: {exc.strerror or exc} !",
              file=sys.stderr)
        return EXIT_CANNOT_WRITE
    tracks_dir = str(store.tracks.resolve()) if spec.tracks else None
    progress = _Progress(len(todo), len(done))
    t0 = time.perf_counter()
    interrupted = False
    stopped: str | None = None
    try:
        if client is not None:
            where = (args.scheduler if args.scheduler else
                     f"a local cluster of {n_workers} worker process"
                     f"{'es' if n_workers > 1 else ''}")
            print(f"{PROG}: {len(todo)} runs to do ({len(done)} already recorded) on {where}",
                  file=sys.stderr, flush=True)
            _run_all(client, spec, todo, store, progress, tracks_dir)
    except KeyboardInterrupt:
        interrupted = True
    except LostCluster as exc:
        stopped = f"lost the cluster mid-campaign ({exc})"
    except OSError as exc:  # a part file cannot be written: stop, keep what is recorded
        stopped = f"{exc.filename or args.out}: cannot write: {exc.strerror or exc} !"
    finally:
        progress.stop()
        store.close()
        if client is not None:
            with contextlib.suppress(Exception):
                client.close(timeout=5)
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close(timeout=5)
    try:
        n, files = write_results(spec, store)
    except OSError as exc:
        print(f"{PROG}: {exc.filename or args.out}: cannot write: {exc.strerror or exc} !",
              file=sys.stderr)
        return EXIT_CANNOT_WRITE
    if interrupted or stopped:
        if stopped:
            print(f"{PROG}: {stopped}", file=sys.stderr)
        print(f"{PROG}: {store.table_path} holds the {n} runs finished so far; run the same "
              "command again to finish", file=sys.stderr)
        if interrupted:
            raise KeyboardInterrupt
        return EXIT_LOST_CLUSTER if stopped.startswith("lost") else EXIT_CANNOT_WRITE
    seconds = time.perf_counter() - t0
    print(f"{PROG}: {n} runs in the table ({progress.done} run now, {progress.failed} failed; "
          f"{len(done)} recorded before) in {seconds:.1f} s")
    for path in files:
        print(f"{PROG}: wrote {path}")
    return EXIT_OK


if __name__ == "__main__":
    raise SystemExit(run_campaign(sys.argv[1:]))
