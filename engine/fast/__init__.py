"""The compiled path of a run, in one room: the reference's hot parts on ``engine.native``.

The navigation modules (geodesy, io, systems, lsq, filter and the cycle) are the reference: pure
Python that reads like the thesis and knows nothing of this package. Here are subclasses and
functions that do the same work through the compiled kernels of :mod:`engine.native`, and
:func:`parts`, which the run loop asks once per run (``engine.run.parts.choose``) for the
collaborators its cycle is built with. A part is offered only when its kernel is built and
current, ``UVNAV_PURE`` is not set, and its first-use probe (a few points computed both ways,
agreeing within the tolerance contract of docs/PERFORMANCE.md) passes; otherwise the run keeps
the reference's part and :func:`declined` says why.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import Any

from engine import native

REL_TOL = 1e-9
"""Relative agreement a probe asks of a kernel's numbers (docs/PERFORMANCE.md)."""


def _close(a: float, b: float, abs_tol: float) -> bool:
    return math.isclose(a, b, rel_tol=REL_TOL, abs_tol=abs_tol)


def _probe_grid() -> str | None:
    """Why the compiled TM grid is not used (None: it is): not built, or a point off."""
    from engine.fast import geodesy
    from engine.geodesy.ellipsoid import WGS84
    from engine.geodesy.tmgrid import TMGrid

    if geodesy.KERNEL is None:
        return native.status("tmgrid")
    fast, ref = geodesy.FastTMGrid(WGS84.ellipsoid, 3.0), TMGrid(WGS84.ellipsoid, 3.0)
    for lat, lon in ((52.0, 3.4), (-33.5, 2.1), (60.25, 3.5)):
        x, y, g, k = fast.forward_full(lat, lon)
        xr, yr, gr, kr = ref.forward_full(lat, lon)
        la, lo = fast.inverse(x, y)
        lar, lor = ref.inverse(xr, yr)
        if not (_close(x, xr, 1e-6) and _close(y, yr, 1e-6) and _close(g, gr, 1e-9)
                and _close(k, kr, 1e-12) and _close(la, lar, 1e-9) and _close(lo, lor, 1e-9)):
            return f"first-use probe failed at ({lat}, {lon})"
    return None


_ED50 = ("ED50", 6378388.0, 297.0, -87.0, -98.0, -121.0)
"""A datum for the probes (International 1924, the demo's ED50 shift to WGS84)."""


def _probe_datum_shift() -> str | None:
    """Why the compiled datum shift is not used (None: it is)."""
    from engine.fast import geodesy
    from engine.geodesy.ellipsoid import WGS84, Datum, Ellipsoid
    from engine.geodesy.ellipsoidal import DatumShift

    if geodesy.DATUM is None:
        return native.status("datum")
    name, a, rf, dx, dy, dz = _ED50
    ed50 = Datum(name, Ellipsoid("INTERNATIONAL", a, rf), dx, dy, dz)
    fast, ref = geodesy.FastDatumShift(WGS84, ed50), DatumShift(WGS84, ed50)
    for q in ((52.0, 3.4, 0.0), (57.7, -1.25, -45.5), (-33.9, 151.2, 100.0)):
        got, want = fast.transform(*q), ref.transform(*q)
        if not (_close(got[0], want[0], 1e-9) and _close(got[1], want[1], 1e-9)
                and _close(got[2], want[2], 1e-6)):
            return f"first-use probe failed at {q}"
    return None


def _probe_geodesic() -> str | None:
    """Why the compiled geodesic azimuths are not used (None: they are). The check is the
    solver's own (:meth:`FastGeodesicSolver.native`: the reference's
    :class:`engine.geodesy.ellipsoidal.GeodesicSolver` on
    :data:`engine.fast.geodesy.GEOD_PROBES`)."""
    from engine.fast import geodesy
    from engine.geodesy.ellipsoid import WGS84

    if geodesy.DECCA is None:
        return native.status("decca")
    if geodesy.FastGeodesicSolver(WGS84.ellipsoid).native() is None:
        return "first-use probe failed (geodesic azimuths)"
    return None


def _probe_systems() -> str | None:
    """Why the compiled Decca and GPS systems are not used (None: they are): the kernels
    are checked on the first epochs of the thesis sample against the reference (the lane
    totals, the fix, the page rows), by :func:`engine.fast.probe.systems`."""
    from engine.fast import decca, gps

    if decca.KERNEL is None or decca.TMGRID is None:
        return native.status("decca" if decca.KERNEL is None else "tmgrid")
    from engine.fast.probe import systems

    return systems(decca.FAST_DECCA, gps.FAST_GPS)


def _probe_fix() -> str | None:
    """Why the compiled fix is not used (None: it is): a GPS + Decca fix both ways
    (:func:`engine.fast.probe.fix`)."""
    from engine.fast import lsq

    if lsq.kernel() is None:
        return native.status("lsq")
    from engine.fast.probe import fix

    return fix(lsq.compute_fix)


def _probe_filter() -> str | None:
    """Why the compiled filter is not used (None: it is): a few cycles of a coloured filter
    both ways (:func:`engine.fast.filter.probe`), on the run's grid (the compiled one where it
    passes its own probe). One check for all the filter's parts (:func:`_as_update`)."""
    from engine.fast import filter as fast_filter
    from engine.geodesy.ellipsoid import WGS84
    from engine.geodesy.tmgrid import TMGrid

    grid = TMGrid(WGS84.ellipsoid, 3.0)
    if _verdict("grid") is None:
        from engine.fast import geodesy

        grid = geodesy.FastTMGrid(WGS84.ellipsoid, 3.0)
    return fast_filter.probe(grid)


def _as_update() -> str | None:
    """The verdict of the filter's other parts: the one of its update (one probe for all)."""
    return _verdict("update")


def _probe_freeze() -> str | None:
    """Why the compiled freezing of a cycle's arrays is not used (None: it is): an update's
    arrays made read-only both ways."""
    from engine.fast import filter as fast_filter

    if fast_filter._FREEZE is None:
        return native.status("outfmt")
    return fast_filter.probe_freeze()


def _probe_make() -> str | None:
    """Why the compiled construction of the cycle's dataclasses is not used (None: it is): one
    built both ways has the same fields."""
    from engine.fast import filter as fast_filter

    if native.kernel("runparse") is None:
        return native.status("runparse")
    return fast_filter.probe_make()
def _probe_run_record() -> str | None:
    """Why the compiled ``.RUN`` quick parser is not used (None: it is)."""
    from engine.fast import runfile

    return runfile.probe()


def _probe_out_writer() -> str | None:
    """Why the compiled ``.OUT`` block writer is not used (None: it is)."""
    from engine.fast import outlog

    return outlog.probe()


def _probe_untrack() -> str | None:
    """Why the compiled untracking of kept results is not used (None: it is)."""
    from engine.fast import retained

    return retained.probe()


_PROBES: dict[str, tuple[str, Callable[[], str | None]]] = {
    "grid": ("tmgrid", _probe_grid),
    "datum_shift": ("datum", _probe_datum_shift),
    "geodesic": ("decca", _probe_geodesic),
    "systems": ("decca", _probe_systems),
    "compute_fix": ("lsq", _probe_fix),
    "update": ("kalman_update", _probe_filter),
    "predict": ("kalman_predict", _as_update),
    "predict_estimate": ("kalman_predict", _as_update),
    "estimate": ("kalman_predict", _as_update),
    "prior": ("runparse", _as_update),
    "update_rows": ("kalman_update", _as_update),
    "update_gated": ("kalman_update", _as_update),
    "innovation_distance": ("kalman_update", _as_update),
    "lse_measurement": ("kalman_predict", _as_update),
    "freeze": ("outfmt", _probe_freeze),
    "make": ("runparse", _probe_make),
    "run_record": ("runparse", _probe_run_record),
    "out_writer": ("outfmt", _probe_out_writer),
    "untrack": ("runparse", _probe_untrack),
}
"""Part of the cycle → (its kernel, its probe)."""


@cache
def _verdict(part: str) -> str | None:
    """Why ``part`` runs the reference (None: compiled); probed once per process."""
    kernel, probe = _PROBES[part]
    if native.pure_requested():
        return native.status(kernel)
    try:
        return probe()
    except Exception as exc:  # a kernel that fails its probe declines, whatever the failure
        return f"first-use probe raised {type(exc).__name__}: {exc}"


def _factory(part: str) -> Any:
    """The compiled object of ``part`` (called only when its verdict is None)."""
    from engine.fast import geodesy

    if part == "grid":
        return geodesy.FastTMGrid
    if part == "datum_shift":
        return geodesy.fast_datum_shift
    if part == "geodesic":
        return geodesy.FastGeodesicSolver
    if part == "systems":
        from engine.fast import decca, gps
        from engine.systems.decca import DECCA
        from engine.systems.gps import GPS

        return {DECCA: decca.FAST_DECCA, GPS: gps.FAST_GPS}
    if part == "compute_fix":
        from engine.fast import lsq

        return lsq.compute_fix
    if part in _FILTER_PARTS:
        from engine.fast import filter as fast_filter

        return getattr(fast_filter, _FILTER_PARTS[part])
    if part == "make":
        from engine.fast.make import slots_maker

        return slots_maker
    if part in _IO_PARTS:
        return _io_part(part)
    raise KeyError(part)


_FILTER_PARTS = {
    "predict": "predict_step",
    "predict_estimate": "predict_estimate",
    "estimate": "filter_estimate",
    "prior": "filter_prior",
    "update": "update",
    "update_rows": "update_rows",
    "update_gated": "update_rows_gated",
    "innovation_distance": "innovation_distance",
    "lse_measurement": "lse_measurement",
    "freeze": "freeze_result",
}
"""Part of the cycle → its function in :mod:`engine.fast.filter`."""


_IO_PARTS = ("run_record", "out_writer", "untrack")
"""The run's input and output parts (engine.fast.runfile, outlog, retained)."""


def _io_part(part: str) -> Any:
    """The compiled object of an input/output part (its verdict is None)."""
    if part == "run_record":
        from engine.fast import runfile

        return runfile.quick_parser()
    if part == "out_writer":
        from engine.fast import outlog

        return outlog.BlockWriter
    from engine.fast import retained

    return retained.untracker()


def parts() -> dict[str, Any]:
    """The compiled parts of a run that pass (name → object, the fields of
    :class:`engine.run.parts.CycleParts`); the others are left to the reference."""
    return {p: _factory(p) for p in _PROBES if _verdict(p) is None}


def declined() -> list[tuple[str, str, str]]:
    """(part, kernel, why) of each part that runs the reference in this process."""
    out = []
    for part, (kernel, _probe) in _PROBES.items():
        why = _verdict(part)
        if why is not None:
            out.append((part, kernel, why))
    return out
