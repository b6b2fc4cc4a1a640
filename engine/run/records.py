"""One cycle as data: the JSON-lines object and the ``.OUT`` block, built from a CycleResult.

Both views come from the same numbers; positions are decimal degrees on the working datum and TM
grid metres on the cycle's CM, ellipse semi-axes in metres at the 95 % level (``a95``, ``b95``)
and the major-axis azimuth in degrees from grid north.
"""

from __future__ import annotations

import math
from datetime import datetime
from math import isfinite, sqrt
from operator import attrgetter
from typing import Any

import numpy as np

from engine.filter.kalman import STATE_LABELS, UpdateResult
from engine.io.outlog import KeyedLines, OutLogWriter, Value
from engine.lsq.confidence import Ellipse, k_factor
from engine.run.cycle import CycleResult, PositionEstimate

P95 = 0.95


def _num(x: float | None, nd: int | None = None) -> float | None:
    """A JSON-safe float (None for NaN/None), optionally rounded to ``nd`` decimals."""
    if x is None:
        return None
    x = float(x)
    if math.isnan(x) or math.isinf(x):
        return None
    return round(x, nd) if nd is not None else x


def position_json(p: PositionEstimate | None) -> dict[str, Any] | None:
    """``{lat, lon, x, y, a95, b95, az_deg}`` of a position estimate (None stays None)."""
    if p is None:
        return None
    a95 = b95 = az = None
    if p.ellipse is not None:
        a, b = p.ellipse.scaled(P95)
        a95, b95, az = _num(a, 3), _num(b, 3), _num(p.ellipse.az_deg, 2)
    return {
        "lat": _num(p.lat_deg, 9),
        "lon": _num(p.lon_deg, 9),
        "x": _num(p.x_m, 3),
        "y": _num(p.y_m, 3),
        "depth": _num(p.depth_m, 2),
        "a95": a95,
        "b95": b95,
        "az_deg": az,
    }


def lse_estimate(r: CycleResult) -> PositionEstimate | None:
    """The cycle's least-squares estimate as a position (None without a proper LSE)."""
    f = r.fix
    if f is None or not f.lse_ok:
        return None
    return PositionEstimate("LSE", f.lat_deg, f.lon_deg, f.x_m, f.y_m, 0.0, f.cov, f.ellipse)


def updates(r: CycleResult) -> list[tuple[str, UpdateResult]]:
    """The cycle's filter updates with their tests, as (kind, result): ``"epoch"`` = the update
    at this epoch (fix or raw LOPs, pressure depth), then ``"sensors"`` = this record's gyro, log
    and inclinometer rows, applied before the step into the epoch (docs/DECISIONS.md, "Sensor
    timing")."""
    out = []
    if r.filter_update is not None:
        out.append(("epoch", r.filter_update))
    if r.sensor_update is not None:
        out.append(("sensors", r.sensor_update))
    return out


def _test_json(kind: str, u: UpdateResult) -> dict[str, Any]:
    return {
        "upd": kind,
        "rows": list(u.labels),
        "lom": _num(u.lom.t, 6),
        "lo": _num(u.lom.lower, 6),
        "hi": _num(u.lom.upper, 6),
        "dof": u.lom.dof,
        "verdict": u.lom.verdict,
        "ls": [_num(t, 3) for t in u.ls.t.tolist()],
    }


def cycle_json(r: CycleResult) -> dict[str, Any]:
    """The JSON-lines object of one cycle (keys documented in docs/FORMATS.md, "JSON lines")."""
    lops = []
    if r.fix is not None:
        for lop in r.fix.lops:
            lops.append({
                "system": lop.system,
                "pattern": lop.pattern,
                "obs": _num(lop.read, 9),
                "corr": _num(lop.correction, 3),
                "calc": _num(lop.calc, 9),
                "v": _num(lop.v_m, 3),
                "w": _num(lop.w, 3),
                "used": lop.used,
                "az_deg": _num(lop.az_deg, 2),
            })
    fs = r.filter_state
    return {
        "n": r.n,
        "time": r.time.strftime("%Y-%m-%dT%H:%M:%SZ"),
        "record": r.record,
        "filter": r.filter_status,
        "source": r.mpp.source,
        "datum": r.datum,
        "cm_deg": r.cm_deg,
        "mpp": position_json(r.mpp),
        "lse": position_json(lse_estimate(r)),
        "kf": position_json(r.kf),
        "kf_pred": position_json(r.kf_pred),
        "lops": lops,
        "s2": _num(r.fix.s2, 5) if r.fix is not None else None,
        "rms": _num(r.fix.rms_m, 3) if r.fix is not None else None,
        "fix_tests": None if r.fix is None or not r.fix.ok else (
            {"failed": True, "cov_scale": _num(r.fix_cov_scale, 6)} if r.fix_fails_tests
            else {"failed": False}),
        "state": None if fs is None else [_num(v, 6) for v in fs.x[: len(STATE_LABELS)]],
        **_gnss_json(r),
        "tests": [_test_json(kind, u) for kind, u in updates(r)],
        **({} if r.adapt is None else {"adapt": {"fix": _num(r.adapt.fix_factor, 4),
                                                 "n": r.adapt.n, **_dr_json(r),
                                                 **_motion_json(r)}}),
        **({} if not r.decca_condition else {"decca_cf": {
            "cf": _num(r.decca_cf, 6), "condition": r.decca_condition}}),
        "messages": list(r.messages),
    }


def _dr_json(r: CycleResult) -> dict[str, Any]:
    """The learnt dead-reckoning noise factor μ and its checks (THEORY §8.19); {} when off."""
    d = r.dr_adapt
    if d is None:
        return {}
    return {"dr": _num(d.mu, 4), "dr_checks": d.n, "dr_nees": _num(d.nees_mean, 3)}


def _motion_json(r: CycleResult) -> dict[str, Any]:
    """The COG/SOG stand-in's learnt process noise (engine.filter.motion), when learnt."""
    m = r.motion
    if m is None:
        return {}
    return {"turn_deg_s": _num(m.turn_rate_max_deg_s, 4), "accel_m2s4": _num(m.sigma_a2, 6),
            "motion_s": _num(m.seconds, 1), "motion_clipped": m.clipped,
            "motion_skipped": m.skipped}


def _gnss_json(r: CycleResult) -> dict[str, Any]:
    """The receiver weight of the GPS fix (``gps_weight``) and the dead-reckoning reference
    (``dr``) of a cycle, only when they differ from a 1993 run's (docs/GNSS_WEIGHTS.md)."""
    out: dict[str, Any] = {}
    w = None if r.gps is None else r.gps.weight
    if w is not None and w.receiver_weighted:
        out["gps_weight"] = {"hdop": w.hdop, "quality": w.quality, "sats": w.sats,
                             "uere_m": w.uere_m, "sigma_m": _num(w.sigma_m, 3),
                             "floored": w.floored}
    if r.sensors.reference != "water":
        out["dr"] = r.sensors.reference
    return out


_K95 = k_factor(P95, 2)
"""The 2-D expansion factor of the 95 % ellipse: :meth:`Ellipse.scaled` (P95) multiplies the
standard semi-axes by exactly this (thesis eq. 5.24–5.25), so ``_K95 * a_m`` is its value."""

_POS_KEYS = ("lat", "lon", "x", "y", "depth")
_ELL_KEYS = ("a95", "b95", "az")
_COV_KEYS = ("cxx", "cxy", "cyy")
_POS_VARIANTS = {
    (False, False): _POS_KEYS,
    (True, False): _POS_KEYS + _ELL_KEYS,
    (False, True): _POS_KEYS + _COV_KEYS,
    (True, True): _POS_KEYS + _ELL_KEYS + _COV_KEYS,
}
"""The position keys by (ellipse present, VCV finite)."""


def _position_row(lat: float, lon: float, x: float, y: float, depth: float,
                  cov: np.ndarray | None,
                  ellipse: Ellipse | None) -> tuple[tuple[str, ...], tuple[Value, ...]]:
    """(keys, values) of the position part of an ``.OUT`` line: geodetic degrees, grid metres,
    depth (m), the 95 % ellipse (m, degrees) and the VCV entries (m²) when finite."""
    values: tuple[Value, ...] = (lat, lon, x, y, depth)
    has_ell = ellipse is not None
    if has_ell:
        values += (_K95 * ellipse.a_m, _K95 * ellipse.b_m, ellipse.az_deg)  # type: ignore[union-attr]
    has_cov = False
    if cov is not None:
        (cxx, cxy), (cyx, cyy) = cov.tolist()
        if isfinite(cxx) and isfinite(cxy) and isfinite(cyx) and isfinite(cyy):
            values += (cxx, cxy, cyy)
            has_cov = True
    return _POS_VARIANTS[has_ell, has_cov], values


def _position_fields(lat: float, lon: float, x: float, y: float, depth: float,
                     cov: np.ndarray | None, ellipse: Ellipse | None) -> dict[str, Value]:
    """The position keys of an ``.OUT`` line as a dict (see :func:`_position_row`)."""
    return dict(zip(*_position_row(lat, lon, x, y, depth, cov, ellipse), strict=True))


def _pos_fields(p: PositionEstimate) -> dict[str, Value]:
    return _position_fields(p.lat_deg, p.lon_deg, p.x_m, p.y_m, p.depth_m, p.cov, p.ellipse)


_KF_KEYS = STATE_LABELS + tuple("s_" + name for name in STATE_LABELS)
"""Keys of the KF line: the 11 navigation states, then their standard deviations."""
_N_NAV = len(STATE_LABELS)
_HEAD_KEYS = ("n", "t", "record", "filter", "source", "datum", "cm", "dt")
_SENSOR_KEYS = ("gyro", "log", "rudder", "incl", "depth", "echo", "conv")
_SENSOR_REF_KEYS = _SENSOR_KEYS + ("ref",)
_SENSOR_STANDIN_KEYS = _SENSOR_REF_KEYS + ("s_hdg", "s_spd")
_GPS_KEYS = ("lat_in", "lon_in", "lat", "lon", "x", "y", "hg")
_GPS_WEIGHT_KEYS = _GPS_KEYS + ("hdop", "q", "sats", "uere", "sigma")
_OBS_KEYS = ("kind", "station", "lat", "lon", "value", "sigma", "sensor")
_LOP_KEYS = ("sys", "pat", "obs", "corr", "calc", "v", "w", "sd", "tau", "az", "used", "verdict")
_LSE_KEYS = ("kind", "n", "cat", "s2", "rms")
_TEST_KEYS = ("lom", "lo", "hi", "dof", "verdict", "ls", "upd", "rows")
_ADAPT_KEYS = ("fix", "n", "clipped")
_ADAPT_DR_KEYS = (*_ADAPT_KEYS, "dr", "checks")
"""The ADAPT line (``[filter] adapt`` on, when the learnt factor moved, docs/FORMATS.md): the
fix-VCV factor λ, the fix epochs learnt from and how many of them hit the clip; with
``[filter] adapt_dr`` the dead-reckoning noise factor μ and the checks it was learnt from."""
_MOTION_KEYS = ("turn", "accel", "s", "n", "clipped", "skipped")
"""The MOTION line (after ADAPT, with the COG/SOG stand-in, docs/FORMATS.md): ψ̇_max (deg/s)
and σ_a² (m²/s⁴) in force, the seconds and lags learnt from, the lags clipped and the COG
samples skipped (engine.filter.motion)."""
_IN = ("\n  IN", ("raw",))
_SYS = ("\n  SYS", ("systems", "sensors"))
_MSG = ("\n  MSG", ("text",))
_NOFIX = ("\n  NOFIX", ("reason",))
_REJECTED = ("rejected",)
_FAILED = ("tests", "cov_scale")


def _sigma(var: float) -> float:
    """Standard deviation of a variance (a negative rounding residue counts as 0; NaN stays)."""
    return sqrt(var) if var > 0.0 else (var if var != var else 0.0)


_UTC_FIELDS = attrgetter("year", "month", "day", "hour", "minute", "second")
_UTC_TEXT = "%04d-%02d-%02dT%02d:%02d:%02dZ"


def _utc_text(t: datetime) -> str:
    """``t.strftime("%Y-%m-%dT%H:%M:%SZ")``, by integer formatting for years 1000–9999 (where
    ``%Y`` is the 4-digit year; any other year goes through ``strftime`` itself): one
    ``attrgetter`` call and one ``%`` (each field a non-negative int, as ``%02d`` writes it)."""
    fields = _UTC_FIELDS(t)
    if 1000 <= fields[0] <= 9999:
        return _UTC_TEXT % fields
    return t.strftime("%Y-%m-%dT%H:%M:%SZ")


_SENS_GET = attrgetter("heading_true_deg", "speed_kn", "rudder_deg", "incl_deg", "depth_m",
                       "echo_m", "convergence_deg")
_GPS_GET = attrgetter("lat_in_deg", "lon_in_deg", "lat_deg", "lon_deg", "x_m", "y_m", "hg_m")
_OBS_GET = attrgetter("kind", "station", "lat_deg", "lon_deg", "value", "sigma", "sensor")
_LOP_GET = attrgetter("system", "pattern", "read", "correction", "calc", "v_m", "w", "sigma_d",
                      "tau", "az_deg", "used", "verdict")
"""The values of the SENS, GPS, OBS and LOP lines in key order, fetched by one C call each
(the same attribute reads, in the same order, as a tuple display of them)."""
_LS_TEXT = "{:.3f}".format
"""``f"{t:.3f}"`` of a float (the same ``float.__format__``) as a bound method for ``map``."""


def cycle_block(r: CycleResult) -> tuple[dict[str, Value], KeyedLines]:
    """The ``.OUT`` block of one cycle: the CYCLE line's fields and the tagged inner lines.

    The inner lines are a :class:`~engine.io.outlog.KeyedLines` (rows of keys and values that
    :meth:`~engine.io.outlog.OutLogWriter.write_cycle` renders by template; read as a sequence
    they are (tag, fields dict) pairs)."""
    mpp = r.mpp
    head: dict[str, Value] = {"n": r.n, "t": _utc_text(r.time), "record": r.record,
                              "filter": r.filter_status, "source": mpp.source,
                              "datum": r.datum, "cm": r.cm_deg, "dt": r.dt_s}
    block = KeyedLines()
    rows = block.rows
    add = rows.append
    s = r.sensors
    sens: tuple[Value, ...] = _SENS_GET(s)
    sens_keys = _SENSOR_KEYS
    if s.reference != "water":  # docs/GNSS_WEIGHTS.md: "ground" = COG/SOG stand-in, "none"
        sens += (s.reference,)
        sens_keys = _SENSOR_REF_KEYS
        if s.standin:
            sens += (s.heading_sigma_deg, s.speed_sigma_ms)
            sens_keys = _SENSOR_STANDIN_KEYS
    add((*_IN, (r.raw,)))
    add((*_SYS, (r.systems, "".join(map(str, s.status)))))
    add(("\n  SENS", sens_keys, sens))
    g = r.gps
    if g is not None:
        gps: tuple[Value, ...] = _GPS_GET(g)
        w = g.weight
        if w is not None and w.receiver_weighted:  # the receiver's weight (GNSS_WEIGHTS.md)
            add(("\n  GPS", _GPS_WEIGHT_KEYS,
                 gps + (w.hdop, w.quality, w.sats, w.uere_m, w.sigma_m)))
        else:
            add(("\n  GPS", _GPS_KEYS, gps))
    for o in r.manual:
        add(("\n  OBS", _OBS_KEYS, _OBS_GET(o)))
    f = r.fix
    if f is not None:
        for lop in f.lops:
            add(("\n  LOP", _LOP_KEYS, _LOP_GET(lop)))
        if f.ok:
            pos_keys, pos = _position_row(f.lat_deg, f.lon_deg, f.x_m, f.y_m, 0.0, f.cov,
                                          f.ellipse)
            keys = _LSE_KEYS + pos_keys
            values = ("hybrid" if f.uses_prior else "lse", f.n_used, f.category, f.s2,
                      f.rms_m) + pos
            if f.rejected_slots:
                keys += _REJECTED
                values += (",".join(str(s) for s in f.rejected_slots),)
            if r.fix_fails_tests:  # issue 15: the fix failed its tests; VCV × scale downstream
                keys += _FAILED
                values += ("fail", r.fix_cov_scale)
            add(("\n  LSE", keys, values))
        else:
            add((*_NOFIX, (f.reason,)))
    p = r.kf_pred
    if p is not None:
        add(("\n  KFP", *_position_row(p.lat_deg, p.lon_deg, p.x_m, p.y_m, p.depth_m, p.cov,
                                        p.ellipse)))
    fs = r.filter_state
    if fs is not None:  # the standard deviations as _sigma, inlined (no call per state)
        add(("\n  KF", _KF_KEYS, (*fs.x[:_N_NAV].tolist(), *[
            sqrt(v) if v > 0.0 else (v if v != v else 0.0)
            for v in fs.P.diagonal()[:_N_NAV].tolist()])))
    for kind, u in updates(r):  # the epoch's update first: readers take the first TEST line
        lom = u.lom
        add(("\n  TEST", _TEST_KEYS, (
            lom.t, lom.lower, lom.upper, lom.dof, lom.verdict,
            ",".join(map(_LS_TEXT, u.ls.t.tolist())), kind, ",".join(u.labels))))
    if r.adapt_logged and r.adapt is not None:  # the learnt fix-VCV factor (THEORY §8.17)
        a, d = r.adapt, r.dr_adapt
        if d is None:
            add(("\n  ADAPT", _ADAPT_KEYS, (a.fix_factor, a.n, a.clipped)))
        else:
            add(("\n  ADAPT", _ADAPT_DR_KEYS, (a.fix_factor, a.n, a.clipped, d.mu, d.n)))
        m = r.motion
        if m is not None:
            add(("\n  MOTION", _MOTION_KEYS, (m.turn_rate_max_deg_s, m.sigma_a2, m.seconds,
                                              m.n, m.clipped, m.skipped)))
    pos_keys, pos = _position_row(mpp.lat_deg, mpp.lon_deg, mpp.x_m, mpp.y_m, mpp.depth_m,
                                  mpp.cov, mpp.ellipse)
    add(("\n  MPP", ("source",) + pos_keys, (mpp.source,) + pos))
    for m in r.messages:
        add((*_MSG, (m,)))
    return head, block


BLOCK_SHAPES = (
    _HEAD_KEYS,
    (_SENSOR_KEYS, _SENSOR_REF_KEYS, _SENSOR_STANDIN_KEYS),
    _GPS_KEYS, _GPS_WEIGHT_KEYS, _OBS_KEYS, _LOP_KEYS,
    tuple(_POS_VARIANTS[bool(i & 1), bool(i & 2)] for i in range(4)),
    tuple(_LSE_KEYS + _POS_VARIANTS[bool(i & 1), bool(i & 2)]
          + (_REJECTED if i & 4 else ()) + (_FAILED if i & 8 else ()) for i in range(16)),
    tuple(("source",) + _POS_VARIANTS[bool(i & 1), bool(i & 2)] for i in range(4)),
    _KF_KEYS, _TEST_KEYS, ("n",), _IN[1], _SYS[1], _MSG[1], _NOFIX[1], _K95, _N_NAV,
    _utc_text,
)
"""What :func:`cycle_block` builds a block from besides the cycle: the key tuples of every line
shape (the position variants indexed by ellipse + 2 × VCV finite, the LSE ones + 4 × rejected
+ 8 × failed), the 95 % factor, the number of navigation states and the time-stamp function.
A writer that builds the block itself (``engine.fast.outlog``) is handed this."""


def write_block(out: OutLogWriter, r: CycleResult) -> None:
    """Write the ``.OUT`` block of ``r`` (:func:`cycle_block`) to ``out`` in one flushed write:
    the reference's block writer (a run may take the compiled one of ``engine.fast.outlog``)."""
    head, lines = cycle_block(r)
    out.write_cycle(head, lines)
