"""Rauch–Tung–Striebel fixed-interval smoother over a completed filter run (THEORY §11.1–11.2).

The thesis lists smoothing as "not implemented" (L2109, L5406); this is the standard RTS pass:

    C_k     = P_k|k Φ_kᵀ P_k+1|k⁻¹                (solved with a Cholesky factor, no inverse)
    x̂_k|N  = x̂_k|k + C_k (x̂_k+1|N − x̂_k+1|k)
    P_k|N   = P_k|k + C_k (P_k+1|N − P_k+1|k) C_kᵀ

States and units are those of :mod:`engine.filter.kalman` (TM grid, m, m/s, rad). Heading
differences
are wrapped to (−π, π] and the smoothed heading is kept in [0, 2π). Fix-error states added
during the run (``add_fix_states``) are handled: when epoch k+1 carries more states than the
prediction from k, the smoothed k+1 estimate is marginalised to the predicted states, which is
exact because the new states enter with a prior independent of everything before.
"""

from __future__ import annotations

import os
import pickle
import struct
import tempfile
from collections.abc import Callable, Hashable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import IO

import numpy as np

from engine.filter.lazy_scipy import cho_factor, cho_solve
from engine.filter.state import IPSI, FilterState
from engine.geodesy.angles import wrap_2pi, wrap_pi

__all__ = ["SmootherRecord", "SmootherSpill", "rts_smooth", "rts_smooth_backward"]



@dataclass(frozen=True)
class SmootherRecord:
    """One epoch of a filter run: x̂_k|k, P_k|k (``filtered``), the prediction x̂_k+1|k, P_k+1|k
    (``predicted_next``) and the Φ_k used for it. The last epoch has no prediction (None)."""

    filtered: FilterState
    predicted_next: FilterState | None = None
    phi: np.ndarray | None = None


def _as_record(r: SmootherRecord | tuple) -> SmootherRecord:
    return r if isinstance(r, SmootherRecord) else SmootherRecord(*r)


def rts_smooth(records: Sequence[SmootherRecord | tuple]) -> list[FilterState]:
    """Smoothed states x̂_k|N, P_k|N for every record, oldest first (same t and metadata).

    ``records`` are :class:`SmootherRecord` or (filtered, predicted_next, Φ) tuples in time
    order; each ``predicted_next.t`` must equal the next record's ``filtered.t`` (s).
    """
    recs = [_as_record(r) for r in records]
    out = [fs for fs, _frame in rts_smooth_backward(
        (r, None) for r in reversed(recs))]
    out.reverse()
    return out


Frame = Hashable
"""What a record's states are expressed in (the session uses the TM grid's CM); equal frames
need no conversion."""


def rts_smooth_backward(
    newest_first: Iterable[tuple[SmootherRecord | tuple, Frame]],
    convert: Callable[[FilterState, Frame, Frame], FilterState] | None = None,
) -> Iterator[tuple[FilterState, Frame]]:
    """The RTS backward pass as a stream: records newest first in, (x̂_k|N, frame) out in the
    same order, holding only the previous smoothed state (memory flat in the run length).

    Each record comes with the frame its states are in; when record k's frame differs from
    the smoothed k+1's, ``convert(state, from, to)`` brings x̂_k+1|N into record k's frame (the
    session re-projects between TM grids; a frame change without ``convert`` is an error).
    """
    nxt: FilterState | None = None
    nxt_frame: Frame = None
    k = -1
    for item, frame in newest_first:
        rec = _as_record(item)
        if nxt is None:
            nxt, nxt_frame = rec.filtered, frame
            yield nxt, frame
            continue
        k -= 1
        if frame != nxt_frame:
            if convert is None:
                raise ValueError(f"record {k}: frame changes from {frame} to {nxt_frame}")
            nxt = convert(nxt, nxt_frame, frame)
        nxt = _rts_step(rec, nxt, k)
        nxt_frame = frame
        yield nxt, frame


def _rts_step(rec: SmootherRecord, nxt: FilterState, k: int) -> FilterState:
    """x̂_k|N, P_k|N from record k and the smoothed k+1 (module doc; k only names errors)."""
    f, pr, Phi = rec.filtered, rec.predicted_next, rec.phi
    if pr is None or Phi is None:
        raise ValueError(f"record {k} has no prediction to the next epoch")
    if abs(pr.t - nxt.t) > 1e-9 * max(1.0, abs(nxt.t)):
        raise ValueError(f"record {k}: prediction time {pr.t} s != next epoch {nxt.t} s")
    m = pr.n
    if nxt.n < m or nxt.fix_states[: len(pr.fix_states)] != pr.fix_states:
        raise ValueError(f"record {k}: next epoch does not extend the predicted state")
    xs_next, Ps_next = nxt.x[:m], nxt.P[:m, :m]
    # C_kᵀ = P_k+1|k⁻¹ Φ P_k|k  (P_k+1|k symmetric), via Cholesky
    Ct = cho_solve(cho_factor(pr.P, lower=True, check_finite=False),
                   Phi.dot(f.P), check_finite=False)
    dx = xs_next - pr.x
    dx[IPSI] = wrap_pi(dx[IPSI])
    x = f.x + Ct.T.dot(dx)
    x[IPSI] = wrap_2pi(x[IPSI])
    P = f.P + Ct.T.dot(Ps_next - pr.P).dot(Ct)
    P = 0.5 * (P + P.T)
    return FilterState(f.t, x, P, f.fix_states, f.fix_tau_s, f.fix_cov)


_LEN = struct.Struct("<q")


class SmootherSpill:
    """A run's smoother records on disk, for runs of any length (issue 15 item 9).

    Records are appended in time order with the frame of their states. The newest stays in
    memory, because the next cycle replaces it (the state after that cycle's sensor update,
    README "Sensor timing"); older ones go to an anonymous temporary file (deleted when closed
    or when the process ends), each as its pickle followed by its length, so the backward pass
    reads the file from the end without an index: memory is one record (~5 kB) whatever the
    run's length; disk is ~4.5 kB per epoch (390 MB for a day at 1 Hz).
    """

    def __init__(self, directory: str | os.PathLike[str] | None = None) -> None:
        self._dir = directory
        self._fh: IO[bytes] | None = None
        self._on_disk = 0
        self._last: tuple[SmootherRecord, Frame] | None = None

    def __len__(self) -> int:
        return self._on_disk + (self._last is not None)

    def _file(self) -> IO[bytes]:
        if self._fh is None:
            self._fh = tempfile.TemporaryFile(dir=self._dir)  # noqa: SIM115
        return self._fh

    @property
    def last(self) -> tuple[SmootherRecord, Frame] | None:
        """The newest record and its frame (None when empty)."""
        return self._last

    def append(self, record: SmootherRecord, frame: Frame) -> None:
        """Add the newest record (the previous newest goes to disk)."""
        if self._last is not None:
            fh = self._file()
            fh.seek(0, os.SEEK_END)
            blob = pickle.dumps(self._last, protocol=pickle.HIGHEST_PROTOCOL)
            fh.write(blob + _LEN.pack(len(blob)))
            self._on_disk += 1
        self._last = (record, frame)

    def replace_last(self, record: SmootherRecord, frame: Frame) -> None:
        """Replace the newest record."""
        if self._last is None:
            raise IndexError("no record to replace")
        self._last = (record, frame)

    def pop(self) -> None:
        """Drop the newest record; the one before it becomes the newest again."""
        if self._last is None:
            raise IndexError("pop from an empty spill")
        self._last = None
        if self._on_disk:
            fh = self._file()
            end = fh.seek(0, os.SEEK_END)
            fh.seek(end - _LEN.size)
            (size,) = _LEN.unpack(fh.read(_LEN.size))
            start = end - _LEN.size - size
            fh.seek(start)
            self._last = pickle.loads(fh.read(size))
            fh.truncate(start)
            self._on_disk -= 1

    def clear(self) -> None:
        """Drop every record (a new smoothing span starts)."""
        self._last = None
        self._on_disk = 0
        if self._fh is not None:
            self._fh.truncate(0)

    def newest_first(self) -> Iterator[tuple[SmootherRecord, Frame]]:
        """Every record with its frame, newest first (read back from the end of the file)."""
        if self._last is None:
            return
        yield self._last
        if not self._on_disk:
            return
        fh = self._file()
        pos = fh.seek(0, os.SEEK_END)
        for _ in range(self._on_disk):
            fh.seek(pos - _LEN.size)
            (size,) = _LEN.unpack(fh.read(_LEN.size))
            pos -= _LEN.size + size
            fh.seek(pos)
            yield pickle.loads(fh.read(size))

    def close(self) -> None:
        """Delete the temporary file."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None
        self._last = None
        self._on_disk = 0
