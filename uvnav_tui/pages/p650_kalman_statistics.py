"""Pg 650, Statistics ▸ KF: the filter's state, its tests and its MPP (THEORY §12.10, D37;
THEORY §8.6, §8.14, §14.4).

The state vector x̂_{k|k} in ``engine.filter.kalman.STATE_LABELS`` order (then any Gauss–Markov
fix-error
states) with σ = √diag P: positions in m, speeds in m/s and kn, angles in degrees.  Then the
Local Overall Model statistic of this cycle's update with its χ² bounds and verdict, the Local
Slippage t_i of every measurement row, and the filter MPP with its ``ConfRegion`` ellipse and
ellipsoid (3-D, from the x/y/depth block of P).
"""

from __future__ import annotations

import math

import numpy as np

from engine.api import (
    KNOT_MS,
    CycleResult,
    FilterState,
    Session,
    UpdateResult,
    error_ellipsoid,
    format_lat_dms,
    format_lon_dms,
)
from uvnav_tui.pages.page_text import TextPage, conf_level, num, pct, state_labels, up_cov3
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 650
TITLE = "Kalman filter statistics :"
SPEEDS = frozenset({"v", "v_cx", "v_cy", "dv"})
ANGLES = frozenset({"psi", "eps", "dpsi", "deps"})
VERDICTS = {"accept": "accept", "monitor": "MONITOR", "reject": "REJECT",
            "too small": "too small (Q/R pessimistic?)", "none": "no test"}


def value_text(label: str, value: float, signed: bool = True) -> str:
    """A state value in its units: ``-31614.82 m``, ``6.548 m/s  12.73 kn``, ``230.15°``."""
    if label in SPEEDS:
        return f"{num(value, 3, 10)} m/s {num(value / KNOT_MS, 2, 7)} kn"
    if label in ANGLES:
        deg = math.degrees(value)
        if label == "psi" and not signed:
            deg %= 360.0
        return f"{num(deg, 3, 10)}°"
    return f"{num(value, 2, 10)} m"


def state_lines(fs: FilterState) -> list[str]:
    """``label  estimate  σ`` for every state."""
    sd = np.sqrt(np.clip(np.diag(fs.P), 0.0, None))
    out = ["State " + "estimate".rjust(10) + " " * 16 + "σ (√P)".rjust(10)]
    for i, label in enumerate(state_labels(fs)):
        est = value_text(label, float(fs.x[i]), signed=label != "psi")
        out.append((label.ljust(6) + est.ljust(26) + value_text(label, float(sd[i]))).rstrip())
    return out


def test_lines(u: UpdateResult | None) -> list[str]:
    """The LOM statistic with its bounds and verdict, and the LS t_i per measurement row."""
    if u is None:
        return ["LOM test : no filter update this cycle"]
    lom = u.lom
    out = [f"LOM test : T = {num(lom.t, 3)}   {num(lom.lower, 3)} < T < {num(lom.upper, 3)}"
           f"  (p = {lom.dof})  {VERDICTS.get(lom.verdict, lom.verdict)}"]
    t = u.ls.t
    flags = u.ls.flags
    ident = u.ls.identified
    for i, label in enumerate(u.labels):
        mark = "   ← identified" if ident == i else ""
        head = "LS test  : " if i == 0 else " " * 11
        out.append(f"{head}{label:<8} t = {num(float(t[i]), 2, 6)}   "
                   f"{VERDICTS.get(flags[i], flags[i])}{mark}")
    return out


def mpp_lines(r: CycleResult, session: Session) -> list[str]:
    """The filter MPP with its ellipse (2-D) and ellipsoid (3-D) at ConfRegion."""
    kf = r.kf
    level = conf_level(session)
    if kf is None:
        return [f"Filter MPP : none this cycle (Filter : {r.filter_status})"]
    out = [f"Filter MPP : {format_lat_dms(kf.lat_deg)}  {format_lon_dms(kf.lon_deg)}"
           f"   depth {num(kf.depth_m, 2)} m"]
    if kf.ellipse is not None:
        a, b = kf.ellipse.scaled(level)
        out.append(f"{pct(level)} ellipse   : a {num(a, 2)} m  b {num(b, 2)} m"
                   f"  Az {num(kf.ellipse.az_deg, 1)}°")
    fs = r.filter_state
    if fs is not None and np.all(np.isfinite(fs.P[:3, :3])):
        e3 = error_ellipsoid(up_cov3(fs.P))
        a3, b3, c3 = e3.scaled(level)
        out.append(f"{pct(level)} ellipsoid : a {num(a3, 2)} m  b {num(b3, 2)} m"
                   f"  c {num(c3, 2)} m  Az {num(e3.az_deg, 1)}°  elev. {num(e3.elev_deg, 1)}°")
    return out


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 650 for cycle ``r``."""
    out = [TITLE, ""]
    fs = r.filter_state
    if fs is None:
        return "\n".join(out + [f"Filter : {r.filter_status}", "",
                                "The filter has not started (gyro and log are needed)."])
    model = "coloured fix errors" if fs.fix_states else "thesis"
    out += [f"Filter : {r.filter_status}   t = {num(fs.t, 1)} s   {fs.n} states ({model})", ""]
    out += state_lines(fs)
    out.append("")
    out += test_lines(r.filter_update)
    if r.sensor_update is not None:
        out += ["", "Sensor update (gyro, log, inclinometer; applied at the previous epoch):"]
        out += test_lines(r.sensor_update)
    out.append("")
    out += adapt_lines(r)
    out += mpp_lines(r, session)
    return "\n".join(out)


def adapt_lines(r: CycleResult) -> list[str]:
    """The learnt fix-VCV factor (``[filter] adapt``, THEORY §8.17) and a blank line; nothing
    when adaptation is off."""
    a = r.adapt
    if a is None:
        return []
    sigma = num(math.sqrt(a.fix_factor), 3)
    return [f"Learnt fix VCV factor : {num(a.fix_factor, 3)}  (σ × {sigma})"
            f"  S² {num(math.exp(a.log_s2), 3)}  NIS {num(math.exp(a.log_nis), 3)}",
            f"                        {a.n} fix epochs, {a.clipped} clipped"
            + ("  AT BOUND" if a.at_bound else ""), *dr_lines(r), *motion_lines(r), ""]


def dr_lines(r: CycleResult) -> list[str]:
    """The learnt dead-reckoning noise factor μ (``[filter] adapt_dr``, THEORY §8.19)."""
    d = r.dr_adapt
    if d is None:
        return []
    last = "—" if d.n == 0 else num(d.nees, 3)
    return [f"Learnt DR noise factor: {num(d.mu, 3)}  (σ × {num(math.sqrt(d.mu), 3)})"
            f"  NEES {last} mean {num(d.nees_mean, 3) if d.n else '—'}",
            f"                        {d.n} checks of {len(d.shadows)} shadows, "
            f"{d.clipped} clipped" + ("  AT BOUND" if d.at_bound else "")]


def motion_lines(r: CycleResult) -> list[str]:
    """The COG/SOG stand-in's learnt process noise (engine.filter.motion); nothing without."""
    m = r.motion
    if m is None:
        return []
    return [f"Learnt stand-in noise : rate of turn {num(m.turn_rate_max_deg_s, 3)}°/s"
            f"  σ_a² {num(m.sigma_a2, 3)} m²/s⁴",
            f"                        {m.seconds / 60.0:.0f} min, {m.n} lags, {m.clipped} "
            f"clipped, {m.skipped} COG skipped"]


class KalmanStatisticsPage(TextPage):
    """Pg 650 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Kalman filter statistics", KalmanStatisticsPage)
