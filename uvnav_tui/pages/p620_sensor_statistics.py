"""Pg 620, Statistics ▸ Sensors (THEORY §12.10, D37; THEORY §14.4, §3.7–3.8).

Per bounded sensor: its status, the raw value of the ``.RUN`` record, the converted value the
program uses (gyro: grid heading ψ − γ; log: m/s; pressure: depth from the crystal frequency),
the sensor's a priori σ in the filter (R of eqs. 6.26b–6.29), and the filter's estimate of its
systematic error with √P: Δψ (gyro, state 9), Δv (log, state 8), Δε (inclinometer, state 10).
Rudder and echo sounder are displayed only; the pressure sensor has no bias state.
"""

from __future__ import annotations

import math

from engine.api import (
    IDEPS,
    IDPSI,
    IDV,
    SENSOR_STATUS_WORD,
    CycleResult,
    FilterState,
    RunRecord,
    Session,
    format_angle_deg,
    format_speed_kn,
    knots_to_ms,
    run_record,
    sensor_measurement,
)
from uvnav_tui.pages.input_kind import InputKind, input_kind
from uvnav_tui.pages.page_text import MISSING, TextPage, num
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 620
TITLE = "Sensor statistics :"
STATUS = SENSOR_STATUS_WORD
HEADER = ("Sensor".ljust(8) + "Stat".ljust(5) + "Raw".ljust(13) + "Converted".ljust(15)
          + "σ".ljust(11) + "KF syst. error".ljust(16) + "   √P")


def sensor_sigmas(r: CycleResult, session: Session) -> dict[str, float]:
    """The filter's a priori σ per measured sensor this cycle (labels z_p, v_m, psi_m, eps_m;
    m, m/s, rad, rad) from the engine's own measurement model."""
    fs: FilterState | None = r.filter_state
    s = r.sensors
    if fs is None:
        return {}
    grid_heading = (None if s.heading_true_deg is None
                    else math.radians(s.heading_true_deg - s.convergence_deg))
    meas = sensor_measurement(
        fs,
        depth_m=s.depth_m,
        log_ms=None if s.speed_kn is None else knots_to_ms(s.speed_kn),
        gyro_grid_rad=grid_heading,
        incl_rad=None if s.incl_deg is None else math.radians(s.incl_deg),
        params=session.context.filter_params,
        log_sigma_ms=s.speed_sigma_ms,
        gyro_sigma_deg=s.heading_sigma_deg,
    )
    return {label: math.sqrt(float(meas.R[i, i])) for i, label in enumerate(meas.labels)}


def _bias(fs: FilterState | None, index: int, angle: bool) -> tuple[str, str]:
    """(estimate, √P) of a bias state in degrees or m/s."""
    if fs is None:
        return MISSING, MISSING
    x, sd = float(fs.x[index]), math.sqrt(max(float(fs.P[index, index]), 0.0))
    if angle:
        return f"{num(math.degrees(x), 3, 7)}°", f"{num(math.degrees(sd), 3, 7)}°"
    return f"{num(x, 3, 7)} m/s", f"{num(sd, 3, 7)} m/s"


def _line(name: str, status: int, raw: str, conv: str, sigma: str, syst: str,
          sd: str) -> str:
    if status != 1:
        raw = conv = MISSING
    return (name.ljust(8) + STATUS.get(status, "?").ljust(5) + raw.ljust(13) + conv.ljust(15)
            + sigma.ljust(11) + syst.ljust(16) + sd).rstrip()


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 620 for cycle ``r``."""
    s = r.sensors
    rec = run_record(r)
    fs = r.filter_state
    kind = input_kind(session)
    sig = sensor_sigmas(r, session)
    st = s.status
    out = [TITLE, "",
           f"Filter : {r.filter_status}    grid convergence γ : {num(s.convergence_deg, 2)}°",
           "", HEADER]

    def raw(value: float | None, fmt: str) -> str:
        return MISSING if rec is None or value is None else fmt.format(value)

    # Gyro: raw true heading, converted grid heading ψ − γ; bias Δψ.
    grid = (MISSING if s.heading_true_deg is None
            else f"{format_angle_deg((s.heading_true_deg - s.convergence_deg) % 360.0)} grid")
    b, sd = _bias(fs, IDPSI, True)
    sigma = f"{num(math.degrees(sig['psi_m']), 2)}°" if "psi_m" in sig else MISSING
    # COG/SOG stand-in (docs/GNSS_WEIGHTS.md): the rows say so with a "*" and show its values.
    # The stand-in's raw values are the record's COG (true) and SOG, as used.
    standin = s.standin
    heading_raw = (MISSING if s.heading_true_deg is None else f"{s.heading_true_deg:.1f}°"
                   ) if standin else raw(rec and rec.heading_deg, "{:.1f}°")
    out.append(_line("COG*" if standin else kind.heading_name, 1 if standin else st[0],
                     heading_raw, grid, sigma, f"Δψ {b}", sd))
    # Log: raw knots, converted m/s; bias Δv.
    conv = MISSING if s.speed_kn is None else f"{num(knots_to_ms(s.speed_kn), 3)} m/s"
    speed_raw = s.speed_kn if standin else (None if rec is None else rec.speed_kn)
    raw_kn = MISSING if speed_raw is None else format_speed_kn(speed_raw)
    b, sd = _bias(fs, IDV, False)
    sigma = f"{num(sig['v_m'], 3)} m/s" if "v_m" in sig else MISSING
    out.append(_line("SOG*" if standin else "Log", 1 if standin else st[1], raw_kn, conv, sigma,
                     f"Δv {b}", sd))
    if kind.nmea:  # NMEA 0183 input has no rudder, inclinometer or pressure sensor
        return _nmea_tail(out, r, rec, kind, st, standin, fs)
    # Rudder: displayed only.
    conv = MISSING if s.rudder_deg is None else format_angle_deg(s.rudder_deg)
    out.append(_line("Rudder", st[2], raw(rec and rec.rudder_deg, "{:.1f}°"), conv, "", "", ""))
    # Inclinometer: degrees; bias Δε.
    conv = MISSING if s.incl_deg is None else f"{num(s.incl_deg, 2)}°"
    b, sd = _bias(fs, IDEPS, True)
    sigma = f"{num(math.degrees(sig['eps_m']), 2)}°" if "eps_m" in sig else MISSING
    out.append(_line("Incl.", st[3], raw(rec and rec.incl_deg, "{:.2f}°"), conv, sigma,
                     f"Δε {b}", sd))
    # Pressure: crystal frequency → depth (eq. 3.3); no bias state.
    conv = MISSING if s.depth_m is None else f"{num(s.depth_m, 2)} m depth"
    sigma = f"{num(sig['z_p'], 2)} m" if "z_p" in sig else MISSING
    out.append(_line("Press.", st[4], raw(rec and rec.press_freq_hz, "{:.3f} Hz"), conv, sigma,
                     "(no bias state)", ""))
    # Echo sounder: displayed only.
    conv = MISSING if s.echo_m is None else f"{num(s.echo_m, 2)} m"
    out.append(_line("Echo", st[5], raw(rec and rec.echo_m, "{:.2f} m"), conv, "", "", ""))
    out += ["",
            "σ: the sensor's a priori σ in the filter (R).  Δψ, Δv, Δε: the filter's",
            "estimates of the systematic errors (states 9, 8, 10), σ = √P.",
            "Rudder and echo sounder: display only."]
    if s.standin:
        out += ["* COG/SOG stand in for the missing gyro/log (sensors.cog_sog): dead reckoning",
                "  over ground with their larger σ; Δψ, Δv are COG/SOG errors and the current",
                "  is only what the fixes show beyond COG/SOG."]
    elif s.reference == "none":
        out.append("No gyro heading or log speed in this record: no dead reckoning (LSE only).")
    if fs is None:
        out.append("The filter has not started: no estimates yet.")
    return "\n".join(out)


def _nmea_tail(out: list[str], r: CycleResult, rec: RunRecord | None, kind: InputKind,
               st: tuple[int, ...], standin: bool, fs: FilterState | None) -> str:
    """The rest of Pg 620 for NMEA input: the echo sounder and COG/SOG rows (as received) and
    the notes; no rudder, inclinometer or pressure rows (NMEA 0183 has none)."""
    s = r.sensors
    if st[5] != 2:
        conv = MISSING if s.echo_m is None else f"{num(s.echo_m, 2)} m"
        raw = MISSING if rec is None or rec.echo_m is None else f"{rec.echo_m:.2f} m"
        out.append(_line("Echo", st[5], raw, conv, "", "", ""))
    if rec is not None and not standin and (rec.cog_deg is not None or rec.sog_kn is not None):
        cog = MISSING if rec.cog_deg is None else f"{rec.cog_deg:.1f}°"
        sog = MISSING if rec.sog_kn is None else format_speed_kn(rec.sog_kn)
        out.append(_line("COG", 1, cog, "(GNSS)", "", "", ""))
        out.append(_line("SOG", 1, sog, "(GNSS)", "", "", ""))
    out += ["",
            "σ: the sensor's a priori σ in the filter (R).  Δψ, Δv: the filter's",
            "estimates of the systematic errors (states 9, 8), σ = √P."]
    if kind.heading == "compass":
        out.append(f"Compass: HDG magnetic heading + {kind.variation}.")
    elif kind.heading == "gyro":
        out.append("Gyro: true heading (HDT).")
    out.append("NMEA input: no rudder, inclinometer or pressure sensor.")
    if standin:
        out += ["* COG/SOG stand in for the missing heading/log (sensors.cog_sog): dead",
                "  reckoning over ground with their larger σ."]
    elif s.reference == "none":
        out.append("No heading or log speed in this record: no dead reckoning (LSE only).")
    if fs is None:
        out.append("The filter has not started: no estimates yet.")
    return "\n".join(out)


class SensorStatisticsPage(TextPage):
    """Pg 620 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Sensor statistics", SensorStatisticsPage)
