"""A run in progress: reads the ``.RUN`` file (or an NMEA 0183 log, docs/NMEA.md), steps the
cycle, applies operator commands and keeps the ``.OUT`` / JSON-lines logs.  The console and the
headless replay both drive this.

The session is the only stateful object of the engine; it holds one run's context and state and
nothing global.  Every completed cycle is on disk (flushed) before :meth:`Session.step` returns.

**Bad records and engine errors.** A record is *bad* when the ``.RUN`` parser rejects it
(:mod:`engine.io.runfile`: grammar and ranges) or when its time does not advance past the previous
processed record's (checked here, before the cycle sees it). A bad record is skipped, counted
(:attr:`Session.skipped_records`), logged as a ``BAD`` line, and the first
:data:`BAD_RECORDS_KEPT` are kept in :attr:`Session.bad_records` with an
:class:`~engine.errors.InputError` naming the ``.RUN`` file, line and field (bounded memory
however many there are); the run goes on. Every other record is valid input
for :func:`engine.run.cycle.step`, which must process it: an exception raised there is an engine
bug,
not a bad record, so it is *not* swallowed. It propagates with a note naming the ``.RUN`` file,
line and text (the log keeps every cycle completed before it). Configuration and data-file names
(datums, the Decca chain, the chains' datums) are checked when the session is built
(:func:`check_config`, :func:`load_data`, :func:`load_run_config`), never per cycle.
"""

from __future__ import annotations

import json
import os
import struct
import tempfile
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from engine import __version__
from engine.errors import InputError
from engine.filter.kalman import FilterState, predict_horizon
from engine.filter.smoother import SmootherRecord, SmootherSpill, rts_smooth_backward
from engine.io.datumfile import DatumFile
from engine.io.deccafile import DeccaChain
from engine.io.nmea_epochs import NmeaStats
from engine.io.nmea_log import NmeaLog, open_records, scan_nmea_log
from engine.io.outlog import OutLogWriter
from engine.io.outputs import OutputFile, OutputGuard
from engine.io.runfile import BadRecord, RunRecord
from engine.lsq.confidence import error_ellipse
from engine.lsq.fix import lop_name
from engine.run.commands import Command, SetDatum, apply_command
from engine.run.config import (
    RunConfig,
    dump_config,
    resolve_vessel,
)
from engine.run.cycle import (
    CycleResult,
    NavState,
    PositionEstimate,
    RunContext,
    build_context,
    filter_estimate,
    initial_state,
    rebase_state,
    reproject_state,
    step,
)
from engine.run.parts import CycleParts
from engine.run.parts import choose as choose_parts
from engine.run.records import BLOCK_SHAPES, cycle_block, cycle_json, write_block
from engine.run.retained import UNTRACK_MIN_HISTORY
from engine.run.setup import (
    CHAIN_FILE,
    DATUM_FILE,
    check_config,
    data_file_warnings,
    load_data,
    load_run_config,
    read_data_dir,
    run_inputs,
)


@dataclass(frozen=True)
class RunSummary:
    """What a replay did: counts, the last cycle and where the logs went."""

    epochs: int
    fixes: int
    rejected_lops: int
    skipped_records: int
    """Bad records and damaged lines skipped: for an NMEA log also those beyond the first of
    each kind that are ``BAD`` lines (:attr:`engine.io.nmea_epochs.NmeaStats.bad_unlisted`)."""
    last: CycleResult | None
    out_path: Path | None
    jsonl_path: Path | None
    eof: bool
    failed_fixes: int = 0
    """LSE fixes that failed their tests (:func:`engine.run.cycle.fix_fit`): used with VCV × S²."""
    flagged_lops: int = 0
    """LOPs whose w-test failed but were kept (LOPReject 'N', or 'A' not yet answered)."""
    gated_fixes: int = 0
    """Fixes kept out of the filter by the gross-error gate."""
    innovation_rejects: int = 0
    """Fixes the filter took although its innovation (LOM) test rejected them."""
    lane_slips: int = 0
    """Decca lane slips corrected against GPS."""
    recoveries: int = 0
    """Times the filter was found diverged and ``[filter] recover`` acted (THEORY §8.18)."""


def cycle_counts(r: CycleResult) -> tuple[int, int, int, int, int]:
    """(flagged LOPs, gated fix, innovation-rejected fix, lane slips, divergence remedy) of one
    cycle: what the replay summary counts."""
    flagged = 0
    if r.fix is not None and r.fix.tested is not None:
        flagged = len(r.fix.tested.flagged) + (r.fix.candidate_slot is not None)
    return (flagged, int(r.fix_gate == "gross"), int(r.fix_gate == "innovation"),
            r.lane_slips, int(r.fix_gate == "recovered"))


NOT_ADVANCING_MESSAGE = "Time does not advance !"
BAD_RECORDS_KEPT = 100
"""Bad records kept in :attr:`Session.bad_records` (the rest are counted and logged only)."""
PENDING_MESSAGES = 20
"""Messages from outside the cycles waiting for the next cycle (:meth:`Session.add_message`)."""


def create_output(
    path: str | os.PathLike[str],
    force: bool = False,
    *,
    guard: OutputGuard | None = None,
    label: str = "--jsonl",
    kind: str = "jsonl",
) -> tuple[OutputFile, Path]:
    """Open a new text output file (UTF-8, ``\\n`` line ends) by the ``.OUT`` rule.

    An existing file is never overwritten: the first free ``stem_N.suffix`` is used instead
    (exclusive create, so two runs never share a file), unless ``force``, which replaces only
    an earlier output of ``kind``; never a file of ``guard`` (:mod:`engine.io.outputs`). Returns
    the open file and the path actually used.
    """
    fh = (guard if guard is not None else OutputGuard()).open(
        path, label=label, kind=kind, force=force)
    return fh, fh.path


def _header_text(text: str) -> str:
    """One ``.OUT`` header line: control characters (a newline in a file name) escaped."""
    return "".join(ch if ch.isprintable() else repr(ch)[1:-1] for ch in text)


def _logged_config(cfg: RunConfig) -> RunConfig:
    """``cfg`` with ``run_file`` and ``data_dir`` absolute, so the TOML in a log header
    reproduces the run wherever the log is read (relative paths would resolve against the
    directory of whatever file the text is loaded from)."""
    return cfg.replace(run_file=str(cfg.run_path), data_dir_text=str(cfg.data_dir))


DR_STEP_S = 10.0
"""Longest prediction step of :meth:`Session.dead_reckon` [s] (the filter's own cycle is the
sample interval, 1–10 s; a longer step would linearise the turn of the heading state over it)."""


class Session:
    """One run: configuration, context, navigation state, logs and a bounded history."""

    def __init__(
        self,
        config: RunConfig,
        *,
        out_path: str | os.PathLike[str] | None = None,
        force: bool = False,
        jsonl_path: str | os.PathLike[str] | None = None,
        history: int = 3600,
        collect_smoother: bool = False,
        data: tuple[DatumFile, dict[str, DeccaChain]] | None = None,
        guard: OutputGuard | None = None,
        records: Iterable[RunRecord | BadRecord] | None = None,
        source_name: str | None = None,
        nmea_scan: NmeaStats | None = None,
    ) -> None:
        """``records`` replaces reading ``config.run_path`` (a live source pushes its records
        with :meth:`process` instead: pass ``records=()``); ``source_name`` names the source in
        messages and the ``.OUT`` header (default the run file). ``filter.vessel = "auto"`` is
        resolved here: "surface" for an NMEA log or a live (NMEA) source (docs/CONFIG.md)."""
        config = resolve_vessel(config, nmea=True if records is not None else None)
        if data is None:
            data = load_data(config)
        else:
            check_config(config, *data)
        self.datums, self.chains = data
        self.parts: CycleParts = choose_parts()
        """The cycle's collaborators for this run: compiled where engine.fast offers them."""
        self.context: RunContext = build_context(config, self.datums, self.chains, self.parts)
        self.nav: NavState = initial_state(config)
        self.history: deque[CycleResult] = deque(maxlen=max(1, history))
        self._untrack = self.parts.untrack if history >= UNTRACK_MIN_HISTORY else None
        """Kept results off the cyclic collector's lists (engine.run.retained) where they are
        kept long enough for it to pay; None too on the reference's parts."""
        self.bad_records: list[BadRecord] = []
        """The first :data:`BAD_RECORDS_KEPT` bad records (all of them are ``BAD`` lines of the
        ``.OUT`` log; :attr:`skipped_records` counts them all): memory stays bounded."""
        self.skipped_records = 0
        self.cycle_config: RunConfig | None = None
        """The configuration the latest cycle was computed with (None before the first): a
        set-up change applies from the next cycle, so what labels that cycle's values (the
        Decca chain of its lanes) is this, not :attr:`config`."""
        self.eof = False
        self.fixes = 0
        self.rejected_lops = 0
        self.failed_fixes = 0
        self.data_warnings: tuple[str, ...] = data_file_warnings(config.data_dir)
        """Data files that differ from the bundled ones (engine.io.datafile_io.modified_bundled);
        written to the .OUT header, shown by the replay."""
        self._counts = [0, 0, 0, 0, 0]  # cycle_counts summed
        self._run_name = source_name if source_name is not None else os.fspath(config.run_path)
        self._records: Iterator[RunRecord | BadRecord] = (
            open_records(self._run_name, config.nmea.options, self.parts.run_record)
            if records is None
            else iter(records))
        self.nmea_stats: NmeaStats | None = None
        """Sentences used/skipped of an NMEA log run file (None for a ``.RUN``); complete at the
        end of the run (docs/NMEA.md)."""
        self.nmea_scan: NmeaStats | None = None
        """What the whole NMEA log gives (sentences used/skipped, events, sensors it lacks),
        read once before the run (``nmea_scan`` if the caller has it) for the ``.OUT`` header
        and the console's start-up messages; None for a ``.RUN``."""
        self.nmea_header: tuple[str, ...] = ()
        if isinstance(self._records, NmeaLog):
            self.nmea_stats = self._records.stats
            self.nmea_scan = nmea_scan or scan_nmea_log(self._run_name, config.nmea.options)
            self.nmea_header = tuple(_header_text(ln) for ln in self.nmea_scan.summary_lines())
        self._since_processed: int | None = None
        """Good records read since the last processed one (None before the first)."""
        self.pending_messages: list[str] = []
        """Messages for the next cycle's ``MSG`` lines from outside the cycle (a live source's
        drops, :meth:`add_message`)."""
        self._prev_nav: NavState | None = None
        self._prev_record: RunRecord | None = None
        self._smoother: SmootherSpill | None = SmootherSpill() if collect_smoother else None
        self._out: OutLogWriter | None = None
        self._write_block: Callable[[OutLogWriter, CycleResult], None] = (
            write_block if self.parts.out_writer is None
            else self.parts.out_writer(BLOCK_SHAPES, cycle_block))
        """Writes a cycle's ``.OUT`` block: the run's part (engine.run.parts), one per run."""
        self._jsonl: OutputFile | None = None
        self.jsonl_path: Path | None = None
        self._open_outputs(config, out_path, jsonl_path, force,
                           guard if guard is not None else OutputGuard())

    def _open_outputs(self, config: RunConfig, out_path: str | os.PathLike[str] | None,
                      jsonl_path: str | os.PathLike[str] | None, force: bool,
                      guard: OutputGuard) -> None:
        """Create the JSONL and .OUT logs (each optional) with the .OUT header."""
        # Both logs follow the .OUT rule (engine/io/outputs.py: never an input, never overwritten:
        # NAME_N; --force replaces an earlier output). Both names are checked before either is
        # created; if the second still cannot be, the first is removed again.
        guard.protect_all(run_inputs(config))
        if jsonl_path is not None:
            guard.check(jsonl_path, "--jsonl")
        if out_path is not None:
            guard.check(out_path, "--out")
        try:
            if jsonl_path is not None:
                self._jsonl, self.jsonl_path = create_output(jsonl_path, force, guard=guard)
            if out_path is not None:
                self._out = OutLogWriter.create(
                    out_path,
                    header=[f"engine {__version__}", f"run {self._run_name}",
                            *(f"warning {w}" for w in self.data_warnings),
                            *(f"nmea {line}" for line in self.nmea_header)],
                    config_text=dump_config(_logged_config(config)),
                    force=force,
                    guard=guard,
                )
        except BaseException:
            self.close()
            if self.jsonl_path is not None and not force:
                self.jsonl_path.unlink(missing_ok=True)
            raise

    @classmethod
    def from_file(cls, config_path: str | os.PathLike[str], **kwargs: object) -> Session:
        """Open a session from a run-configuration TOML file (names checked and located as by
        :func:`load_run_config`)."""
        cfg, data = load_run_config(config_path)
        return cls(cfg, data=data, **kwargs)  # type: ignore[arg-type]

    # ------------------------------------------------------------------ properties
    @property
    def config(self) -> RunConfig:
        """The configuration in force (changes with every set-up command)."""
        return self.context.config

    @property
    def last(self) -> CycleResult | None:
        """The most recent cycle, or None before the first."""
        return self.history[-1] if self.history else None

    @property
    def out_path(self) -> Path | None:
        """Where the ``.OUT`` log is written (None when not logging)."""
        return self._out.path if self._out is not None else None

    # ------------------------------------------------------------------ running
    def _next_record(self) -> RunRecord | None:
        for item in self._records:
            rec = self._admit(item)
            if rec is not None:
                return rec
        self.eof = True
        return None

    def _admit(self, item: RunRecord | BadRecord) -> RunRecord | None:
        """The record if the run processes it now; None for a bad one (logged, kept) or one
        DeltaT skips."""
        if isinstance(item, BadRecord):
            self._log_bad(item.line_no, item.error.field or "record", item.error.message,
                          item.raw)
            self._keep_bad(item)
            return None
        # DeltaT: process every DeltaT-th record (THEORY D43), counted from the last
        # processed one, so a new DeltaT takes effect from the next cycle.
        delta = self.context.config.demo.delta_t_s  # self.config, without the property call
        since = delta if self._since_processed is None else self._since_processed + 1
        if since < delta:
            self._since_processed = since
            return None
        self._since_processed = 0
        return item

    def _log_bad(self, line_no: int, field: str, message: str, raw: str) -> None:
        if self._out is not None:
            self._out.write_bad_record({"record": line_no, "field": field, "message": message,
                                        "raw": raw})

    def step(self) -> CycleResult | None:
        """Process the next good record; None at the end of the file.

        A bad record (module docstring) is skipped and reported; an exception from the cycle
        itself is an engine bug and propagates with a note naming the record.
        """
        while True:
            rec = self._next_record()
            if rec is None:
                return None
            result = self._cycle(rec)
            if result is not None:
                return result

    def process(self, item: RunRecord | BadRecord) -> CycleResult | None:
        """Process one record pushed by the caller (a live source, docs/LIVE.md) exactly as
        :meth:`step` processes the next record of the file: a cycle, or None when the record is
        bad, skipped by DeltaT or not later than the last one (each logged as in :meth:`step`)."""
        rec = self._admit(item)
        return None if rec is None else self._cycle(rec)

    def _cycle(self, rec: RunRecord) -> CycleResult | None:
        """One cycle for ``rec``; None (rejected, logged) if its time does not advance."""
        last = self.nav.last_time
        if last is not None and rec.time <= last:
            self._reject(rec, InputError(
                NOT_ADVANCING_MESSAGE, file=self._run_name, line=rec.line_no, field="time",
                text=rec.raw.split()[1] if len(rec.raw.split()) > 1 else rec.time.isoformat(),
            ))
            return None
        try:
            nav, result = step(self.context, self.nav, rec)
        except Exception as exc:
            exc.add_note(f"while processing {self._run_name}:{rec.line_no}: {rec.raw!r}")
            raise
        self._prev_nav, self._prev_record = self.nav, rec
        if self.pending_messages:
            result = replace(result, messages=(*result.messages, *self.pending_messages))
            self.pending_messages = []
        self._commit(nav, result)
        return result

    def add_message(self, text: str) -> None:
        """A message the next cycle carries (its ``MSG`` line in the ``.OUT``, the console's
        message line): what happened outside the cycles, e.g. a live source's drops. At most
        :data:`PENDING_MESSAGES` wait; beyond that the oldest goes."""
        if len(self.pending_messages) >= PENDING_MESSAGES:
            del self.pending_messages[0]
        self.pending_messages.append(text)

    def _reject(self, rec: RunRecord, error: InputError) -> None:
        """Skip a parsed record the run cannot use: log it (``BAD``) and keep it."""
        self._log_bad(rec.line_no, error.field or "record", error.message, rec.raw)
        self._keep_bad(BadRecord(rec.line_no, rec.raw, error))

    def _keep_bad(self, bad: BadRecord) -> None:
        """Count a bad record; keep only the first :data:`BAD_RECORDS_KEPT` in memory."""
        self.skipped_records += 1
        if len(self.bad_records) < BAD_RECORDS_KEPT:
            self.bad_records.append(bad)

    def _commit(self, nav: NavState, result: CycleResult) -> None:
        if self._smoother is not None and nav.filter is not None:
            self._collect_smoother(nav, result)
        self.nav = nav
        self.cycle_config = self.context.config
        if self._untrack is not None:  # kept for `history` cycles: off the cyclic GC's lists
            self._untrack(result)
        self.history.append(result)
        # The counts, with cycle_counts(result) summed into self._counts written out (each
        # added only where it is not 0, as the loop over cycle_counts did).
        counts = self._counts
        fix = result.fix
        if fix is not None:
            if fix.lse_ok:
                self.fixes += 1
            if fix.rejected_slots:
                self.rejected_lops += len(fix.rejected_slots)
            if fix.tested is not None:
                flagged = len(fix.tested.flagged) + (fix.candidate_slot is not None)
                if flagged:
                    counts[0] += flagged
        if result.fix_fails_tests:
            self.failed_fixes += result.fix_fails_tests
        gate = result.fix_gate
        if gate:
            if gate == "gross":
                counts[1] += 1
            elif gate == "innovation":
                counts[2] += 1
            elif gate == "recovered":
                counts[4] += 1
        if result.lane_slips:
            counts[3] += result.lane_slips
        out = self._out
        if out is not None:
            self._write_block(out, result)
        if self._jsonl is not None:
            self._jsonl.write(json.dumps(cycle_json(result), separators=(",", ":")) + "\n")
            self._jsonl.flush()

    def _collect_smoother(self, nav: NavState, result: CycleResult) -> None:
        """Keep what the RTS smoother needs: per epoch the final filter state, and for the step
        into the next epoch the state it started from, the prediction and Φ, each record with
        the CM of its grid (spilled to disk: engine.filter.smoother.SmootherSpill)."""
        assert self._smoother is not None and nav.filter is not None
        recs = self._smoother
        link = result.smoother_link
        last = recs.last
        if last is not None and link is not None:
            start, pred, phi = link
            prev = last[0].filtered
            if start.n == prev.n and start.fix_states == prev.fix_states:
                # The link is on this cycle's grid (the cycle re-projected a CM change).
                recs.replace_last(SmootherRecord(start, pred, phi), result.cm_deg)
            else:
                recs.clear()  # the state changed shape (fix states added): restart the span
        elif link is None:
            recs.clear()
        recs.append(SmootherRecord(nav.filter), result.cm_deg)

    def recompute_last(self, excluded_slots: tuple[int, ...]) -> CycleResult | None:
        """Redo the last cycle with LOPs discarded (``LOPReject = 'A'``, the operator said yes)."""
        if self._prev_record is None or self._prev_nav is None:
            return None
        nav, result = step(self.context, self._prev_nav, self._prev_record,
                           excluded_slots=excluded_slots)
        dropped = self.history.pop()
        if dropped.fix is not None:
            self.fixes -= int(dropped.fix.lse_ok)
            self.rejected_lops -= len(dropped.fix.rejected_slots)
        self.failed_fixes -= dropped.fix_fails_tests
        for i, c in enumerate(cycle_counts(dropped)):
            self._counts[i] -= c
        if self._smoother:
            self._smoother.pop()
        self._lop_action(result, "discarded", excluded_slots)
        self._commit(nav, result)
        return result

    def _lop_action(self, result: CycleResult, verb: str, slots: tuple[int, ...]) -> None:
        """The ``ACT`` line of an operator's answer about flagged LOPs of cycle ``result``
        (``LOP discarded (2,): Decca Red``)."""
        if self._out is None:
            return
        system = "KF" if result.fix is not None and result.fix.uses_prior else "GPS"
        names = ", ".join(lop_name(s, system=system, manual=result.manual) for s in slots)
        self._out.write_action({"cycle": result.n, "text": f"LOP {verb} {slots}: {names}"})

    def record_lop_kept(self, slot: int) -> None:
        """The operator kept the LOP in ``slot`` that the last cycle flagged (LOPReject 'A',
        no): an ``ACT`` line in the ``.OUT``, as a discarded one has (``LOP kept (2,): Decca
        Red``)."""
        if self.history:
            self._lop_action(self.history[-1], "kept", (slot,))

    def run(
        self,
        max_cycles: int | None = None,
        progress: Callable[[CycleResult], None] | None = None,
    ) -> RunSummary:
        """Step until the end of the file (or ``max_cycles``); returns the summary."""
        n = 0
        while max_cycles is None or n < max_cycles:
            r = self.step()
            if r is None:
                break
            n += 1
            if progress is not None:
                progress(r)
        return self.summary()

    def summary(self) -> RunSummary:
        """Counts so far."""
        return RunSummary(
            epochs=len(self.history) if self.last is None else self.last.n,
            fixes=self.fixes,
            rejected_lops=self.rejected_lops,
            skipped_records=self.skipped_records + (
                0 if self.nmea_stats is None else self.nmea_stats.bad_unlisted),
            last=self.last,
            out_path=self.out_path,
            jsonl_path=self.jsonl_path,
            eof=self.eof,
            failed_fixes=self.failed_fixes,
            flagged_lops=self._counts[0],
            gated_fixes=self._counts[1],
            innovation_rejects=self._counts[2],
            lane_slips=self._counts[3],
            recoveries=self._counts[4],
        )

    # ------------------------------------------------------------------ operator
    def apply(self, cmd: Command) -> str:
        """Apply an operator command between cycles; logs it and returns its description."""
        cfg, nav, text = apply_command(self.context, self.nav, cmd)
        if cfg is not self.context.config:
            check_config(cfg, self.datums, self.chains)
            old = self.context
            new = build_context(cfg, self.datums, self.chains, self.parts)
            if isinstance(cmd, SetDatum):
                nav = rebase_state(nav, old, new)
            self.context = new
        self.nav = nav
        if self._out is not None:
            self._out.write_action({
                "cycle": self.nav.n,
                "t": None if nav.last_time is None else nav.last_time.strftime("%H:%M:%SZ"),
                "text": text,
            })
        return text

    def predict(self, horizon_s: float, step_s: float) -> list[PositionEstimate]:
        """Kalman ▸ Predict: positions and ellipses every ``step_s`` s up to ``horizon_s`` s,
        from the current filter state (which is not changed)."""
        fs = self.nav.filter
        if fs is None or self.nav.cm_deg is None:
            return []
        grid = self.context.grid(self.nav.cm_deg)
        out = []
        for s in predict_horizon(fs, horizon_s, step_s, self.context.filter_params):
            out.append(filter_estimate("KF", grid, s))
        return out

    @property
    def source_name(self) -> str:
        """The run's source as the ``.OUT`` header names it: the run file's path, or a live
        source's URL."""
        return self._run_name

    def dead_reckon(self, elapsed_s: float) -> PositionEstimate | None:
        """The MPP dead-reckoned ``elapsed_s`` seconds past the last cycle without a
        measurement (a live source lost: the wall clock runs on while no record comes). The
        filter's own prediction (THEORY §8.15, as Kalman ▸ Predict) from its last state: the
        last heading, speed and current carried on, its covariance grown by the process noise;
        steps of at most :data:`DR_STEP_S`. Source ``DR``; None without a filter state; the
        session is not changed."""
        fs = self.nav.filter
        if fs is None or self.nav.cm_deg is None or not elapsed_s > 0.0:
            return None
        grid = self.context.grid(self.nav.cm_deg)
        states = predict_horizon(fs, elapsed_s, DR_STEP_S, self.context.filter_params)
        return filter_estimate("DR", grid, states[-1])

    def smooth(self) -> list[PositionEstimate]:
        """Kalman ▸ Smoothing: RTS-smoothed positions of the collected span (oldest first, on
        the grid of the current CM). A list: for a long run use :meth:`iter_smoothed`."""
        return list(self.iter_smoothed())

    def iter_smoothed(self) -> Iterator[PositionEstimate]:
        """The smoothed positions of the collected span, oldest first, on the grid of the
        current CM, streamed: the backward pass writes 7 numbers per epoch to a temporary file
        and this reads them back in time order (memory flat in the run length, ~56 bytes of
        disk per epoch besides the records' spill)."""
        if not self._smoother or self.nav.cm_deg is None:
            return
        ctx = self.context
        final_cm = self.nav.cm_deg

        def convert(fs: FilterState, old: object, new: object) -> FilterState:
            return reproject_state(fs, ctx.grid(float(old)),  # type: ignore[arg-type]
                                   ctx.grid(float(new)))  # type: ignore[arg-type]

        def records() -> Iterator[tuple[SmootherRecord, float]]:
            first = True
            for rec, cm in self._smoother.newest_first():  # type: ignore[union-attr]
                if first and rec.predicted_next is not None:
                    rec = SmootherRecord(rec.filtered)
                first = False
                yield rec, cm

        packed = struct.Struct("<7d")
        with tempfile.TemporaryFile() as fh:
            n = 0
            for fs, cm in rts_smooth_backward(records(), convert):
                if cm != final_cm:
                    fs = convert(fs, cm, final_cm)
                P = fs.position_cov_m2
                fh.write(packed.pack(fs.t, *fs.east_north_m, fs.depth_m, P[0, 0], P[0, 1],
                                     P[1, 1]))
                n += 1
            grid = ctx.grid(final_cm)
            for i in range(n - 1, -1, -1):
                fh.seek(i * packed.size)
                _t, x, y, z, pxx, pxy, pyy = packed.unpack(fh.read(packed.size))
                cov = np.array([[pxx, pxy], [pxy, pyy]])
                lat, lon = grid.inverse(x, y)
                ell = error_ellipse(cov) if np.isfinite(cov).all() else None
                cov.setflags(write=False)  # as engine.run.cycle's estimates: immutable values
                if ell is not None:
                    ell.eigenvectors.setflags(write=False)
                yield PositionEstimate("SMO", lat, lon, x, y, z, cov, ell)

    def close(self) -> None:
        """Close the logs (everything written is already flushed) and drop the smoother's
        spill file; every one is closed even if closing another fails (the OSError names its
        file)."""
        try:
            if self._smoother is not None:
                self._smoother.close()
        finally:
            try:
                if self._out is not None:
                    self._out.close()
            finally:
                if self._jsonl is not None:
                    self._jsonl.close()

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


__all__ = [
    "CHAIN_FILE",
    "DATUM_FILE",
    "RunSummary",
    "Session",
    "check_config",
    "create_output",
    "data_file_warnings",
    "load_data",
    "load_run_config",
    "read_data_dir",
    "run_inputs",
    "replace",
]
