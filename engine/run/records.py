"""One cycle as data: the JSON-lines object and the ``.OUT`` block, built from a CycleResult.

Both views come from the same numbers; positions are decimal degrees on the working datum and TM
grid metres on the cycle's CM, ellipse semi-axes in metres at the 95 % level (``a95``, ``b95``)
and the major-axis azimuth in degrees from grid north.
"""

from __future__ import annotations

import math
from math import isfinite, sqrt
from typing import Any

import numpy as np

from engine.filter.kalman import STATE_LABELS, UpdateResult
from engine.io.outlog import Value
from engine.lsq.confidence import Ellipse
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
    and inclinometer rows, applied before the step into the epoch (README "Sensor timing")."""
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
    """The JSON-lines object of one cycle (keys documented in README, "Replay outputs")."""
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
        "messages": list(r.messages),
    }


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


def _position_fields(lat: float, lon: float, x: float, y: float, depth: float,
                     cov: np.ndarray | None, ellipse: Ellipse | None) -> dict[str, Value]:
    """The position keys of an ``.OUT`` line: geodetic degrees, grid metres, depth (m), the 95 %
    ellipse (m, degrees) and the VCV entries (m²) when finite."""
    out: dict[str, Value] = {"lat": lat, "lon": lon, "x": x, "y": y, "depth": depth}
    if ellipse is not None:
        a, b = ellipse.scaled(P95)
        out["a95"], out["b95"], out["az"] = a, b, ellipse.az_deg
    if cov is not None:
        (cxx, cxy), (cyx, cyy) = cov.tolist()
        if isfinite(cxx) and isfinite(cxy) and isfinite(cyx) and isfinite(cyy):
            out["cxx"], out["cxy"], out["cyy"] = cxx, cxy, cyy
    return out


def _pos_fields(p: PositionEstimate) -> dict[str, Value]:
    return _position_fields(p.lat_deg, p.lon_deg, p.x_m, p.y_m, p.depth_m, p.cov, p.ellipse)


_KF_KEYS = STATE_LABELS + tuple("s_" + name for name in STATE_LABELS)
"""Keys of the KF line: the 11 navigation states, then their standard deviations."""
_SENSOR_KEYS = ("gyro", "log", "rudder", "incl", "depth", "echo", "conv")
_GPS_KEYS = ("lat_in", "lon_in", "lat", "lon", "x", "y", "hg")


def _sigma(var: float) -> float:
    """Standard deviation of a variance (a negative rounding residue counts as 0; NaN stays)."""
    return sqrt(var) if var > 0.0 else (var if var != var else 0.0)


def cycle_block(
    r: CycleResult,
) -> tuple[dict[str, Value], list[tuple[str, dict[str, Value]]]]:
    """The ``.OUT`` block of one cycle: the CYCLE line's fields and the tagged inner lines."""
    head: dict[str, Value] = {
        "n": r.n,
        "t": r.time.strftime("%Y-%m-%dT%H:%M:%SZ"),
        "record": r.record,
        "filter": r.filter_status,
        "source": r.mpp.source,
        "datum": r.datum,
        "cm": r.cm_deg,
        "dt": r.dt_s,
    }
    s = r.sensors
    sens: dict[str, Value] = dict(zip(_SENSOR_KEYS, (s.heading_true_deg, s.speed_kn,
                                                     s.rudder_deg, s.incl_deg, s.depth_m,
                                                     s.echo_m, s.convergence_deg), strict=True))
    if s.reference != "water":  # docs/GNSS_WEIGHTS.md: "ground" = COG/SOG stand-in, "none"
        sens["ref"] = s.reference
        if s.standin:
            sens["s_hdg"], sens["s_spd"] = s.heading_sigma_deg, s.speed_sigma_ms
    lines: list[tuple[str, dict[str, Value]]] = [
        ("IN", {"raw": r.raw}),
        ("SYS", {"systems": r.systems, "sensors": "".join(map(str, s.status))}),
        ("SENS", sens),
    ]
    if r.gps is not None:
        g = r.gps
        gps: dict[str, Value] = dict(zip(_GPS_KEYS, (g.lat_in_deg, g.lon_in_deg, g.lat_deg,
                                                     g.lon_deg, g.x_m, g.y_m, g.hg_m),
                                         strict=True))
        w = g.weight
        if w is not None and w.receiver_weighted:  # the receiver's weight (GNSS_WEIGHTS.md)
            gps.update({"hdop": w.hdop, "q": w.quality, "sats": w.sats, "uere": w.uere_m,
                        "sigma": w.sigma_m})
        lines.append(("GPS", gps))
    for o in r.manual:
        lines.append(("OBS", {"kind": o.kind, "station": o.station, "lat": o.lat_deg,
                              "lon": o.lon_deg, "value": o.value, "sigma": o.sigma,
                              "sensor": o.sensor}))
    f = r.fix
    if f is not None:
        for lop in f.lops:
            lines.append(("LOP", {
                "sys": lop.system, "pat": lop.pattern, "obs": lop.read, "corr": lop.correction,
                "calc": lop.calc, "v": lop.v_m, "w": lop.w, "sd": lop.sigma_d, "tau": lop.tau,
                "az": lop.az_deg, "used": lop.used, "verdict": lop.verdict,
            }))
        if f.ok:
            fields: dict[str, Value] = {"kind": "hybrid" if f.uses_prior else "lse",
                                        "n": f.n_used, "cat": f.category, "s2": f.s2,
                                        "rms": f.rms_m}
            fields.update(_position_fields(f.lat_deg, f.lon_deg, f.x_m, f.y_m, 0.0, f.cov,
                                           f.ellipse))
            if f.rejected_slots:
                fields["rejected"] = ",".join(str(s) for s in f.rejected_slots)
            if r.fix_fails_tests:  # issue 15: the fix failed its tests; VCV × scale downstream
                fields["tests"] = "fail"
                fields["cov_scale"] = r.fix_cov_scale
            lines.append(("LSE", fields))
        else:
            lines.append(("NOFIX", {"reason": f.reason}))
    if r.kf_pred is not None:
        lines.append(("KFP", _pos_fields(r.kf_pred)))
    fs = r.filter_state
    if fs is not None:
        n_nav = len(STATE_LABELS)
        values = fs.x[:n_nav].tolist() + [_sigma(v) for v in fs.P.diagonal()[:n_nav].tolist()]
        lines.append(("KF", dict(zip(_KF_KEYS, values, strict=True))))
    for kind, u in updates(r):  # the epoch's update first: readers take the first TEST line
        lines.append(("TEST", {"lom": u.lom.t, "lo": u.lom.lower, "hi": u.lom.upper,
                               "dof": u.lom.dof, "verdict": u.lom.verdict,
                               "ls": ",".join([f"{t:.3f}" for t in u.ls.t.tolist()]),
                               "upd": kind, "rows": ",".join(u.labels)}))
    lines.append(("MPP", {"source": r.mpp.source, **_pos_fields(r.mpp)}))
    for m in r.messages:
        lines.append(("MSG", {"text": m}))
    return head, lines
