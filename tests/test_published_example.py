"""Published single-point adjustments reproduced to their published coordinates.

Source actually read (not the books themselves): the example files of F. Krumm, "Geodetic
Network Adjustment Examples", Geodätisches Institut, Universität Stuttgart, Rev. 3.5
(20 January 2020), in the copy distributed with GNU Gama: each ``*.dat`` holds the book's data,
each ``*.adj`` "the adjusted coordinates, as published by Friedhelm Krumm" (GNU Gama README of
that directory). Files read: ``2D/Ghilani15_5_Angle_fix.{dat,adj}``,
``2D/Ghilani15_4_Angle_fix.{dat,adj}``, ``2D/Benning88_Distance_fix.{dat,adj}`` (vendored at
github.com/kauevestena/geocomp, tests/data/krumm/2D/). The ``.adj`` rows are
``name x dx[cm] σx[cm] y dy[cm] σy[cm] σp[cm]``; σ are a posteriori (σ̂0² = S² scaling).

Coordinates: x = East, y = North; azimuths from North clockwise (Ghilani's convention, which
reproduces the observed angles from the given coordinates). Angles in gon as in Krumm's files.
Tolerance = the published rounding: coordinates 4 dp → ±0.05 mm; σ 3 dp in cm → ±0.005 mm.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.adjustment import Linearisation, gauss_newton

GON = math.pi / 200.0
COORD_TOL = 0.5e-4  # m, half a unit of the printed 0.1 mm
SIGMA_TOL = 0.5e-5  # m, half a unit of the printed 0.001 cm


def _az(frm: np.ndarray, to: np.ndarray) -> tuple[float, np.ndarray]:
    """Grid azimuth frm→to (rad, from North clockwise) and its gradient w.r.t. ``to``."""
    dx, dy = float(to[0] - frm[0]), float(to[1] - frm[1])
    d2 = dx * dx + dy * dy
    return math.atan2(dx, dy), np.array([dy, -dx]) / d2


def _angle_model(points: dict[str, np.ndarray], angles: list[tuple[str, str, str, float, float]],
                 unknown: str):
    """Horizontal angles at ``station`` from ``bs`` to ``fs`` (gon, σ gon) with one unknown
    point: angle = Az(station→fs) − Az(station→bs); rows in rad per metre, C_l in rad²."""
    C = np.diag([(s * GON) ** 2 for *_, s in angles])
    obs = np.array([val * GON for *_, val, _ in angles])

    def lin(x: np.ndarray) -> Linearisation:
        P = dict(points)
        P[unknown] = x
        A = np.zeros((len(angles), 2))
        b = np.zeros(len(angles))
        for i, (st, bs, fs, _, _) in enumerate(angles):
            az_f, g_f = _az(P[st], P[fs])
            az_b, g_b = _az(P[st], P[bs])
            calc = az_f - az_b
            b[i] = (obs[i] - calc + math.pi) % (2.0 * math.pi) - math.pi
            if st == unknown:  # ∂Az/∂from = −∂Az/∂to
                A[i] += -g_f + g_b
            if fs == unknown:
                A[i] += g_f
            if bs == unknown:
                A[i] -= g_b
        return Linearisation(A, b, C)

    return lin


def test_ghilani_example_15_5_resection() -> None:
    """Ghilani (2010), Adjustment Computations, 5th ed., Wiley, ISBN 978-0-470-46491-5,
    Example 15.5 (resection), p. 277: three angles observed at U to P, Q, R, S
    (Krumm's file gives them in gon; converted they are 30°29'33" ±5", 38°30'31" ±6",
    10°29'57" ±6").
    Published (Krumm .adj): U = (999.9989, 1000.0253), σ 2.057 / 4.268 cm, σp 4.738 cm."""
    points = {
        "P": np.array([1303.599, 1458.615]),
        "Q": np.array([1636.436, 1310.468]),
        "R": np.array([1503.395, 888.362]),
        "S": np.array([1506.262, 785.061]),
    }
    angles = [
        ("U", "P", "Q", 33.8805555555556, 0.00154320987654321),
        ("U", "Q", "R", 42.7873456790123, 0.00185185185185185),
        ("U", "R", "S", 11.6657407407407, 0.00185185185185185),
    ]
    x0 = np.array([1000.030, 999.960])  # the book's approximate coordinates
    adj = gauss_newton(_angle_model(points, angles, "U"), x0, np.ones(3, bool),
                       epsilon=1e-6, scale_vcv=True)
    assert adj.ok and adj.category == "III"
    assert adj.x[0] == pytest.approx(999.9989, abs=COORD_TOL)
    assert adj.x[1] == pytest.approx(1000.0253, abs=COORD_TOL)
    # the published corrections from the approximate point: −3.110 / +6.530 cm (3 dp)
    assert (adj.x - x0) * 100.0 == pytest.approx([-3.110, 6.530], abs=0.0005)
    sx, sy = np.sqrt(np.diag(adj.cov_x))
    assert sx == pytest.approx(0.02057, abs=SIGMA_TOL)
    assert sy == pytest.approx(0.04268, abs=SIGMA_TOL)
    assert adj.drms_m == pytest.approx(0.04738, abs=SIGMA_TOL)  # σp = sqrt(σx² + σy²)


def test_ghilani_example_15_4_intersection() -> None:
    """Ghilani (2010), Example 15.4 (intersection), p. 271: four angles at the known stations
    R, S, T turned to the new point U, σ 0.001 gon (Krumm's [Angles] section).
    Published (Krumm .adj): U = (6860.7260, 3727.4751), σ 37.817 / 17.809 cm, σp 41.801 cm."""
    points = {
        "R": np.array([865.40, 4527.15]),
        "S": np.array([2432.55, 2047.25]),
        "T": np.array([2865.22, 27.15]),
    }
    angles = [
        ("R", "U", "S", 55.6820987654321, 0.001),
        ("S", "R", "U", 112.792283950617, 0.001),
        ("S", "U", "T", 109.653395061728, 0.001),
        ("T", "S", "U", 65.8706790123457, 0.001),
    ]
    x0 = np.array([6861.35, 3727.59])
    adj = gauss_newton(_angle_model(points, angles, "U"), x0, np.ones(4, bool),
                       epsilon=1e-6, scale_vcv=True)
    assert adj.ok and adj.category == "IV"
    assert adj.x[0] == pytest.approx(6860.7260, abs=COORD_TOL)
    assert adj.x[1] == pytest.approx(3727.4751, abs=COORD_TOL)
    sx, sy = np.sqrt(np.diag(adj.cov_x))
    assert sx == pytest.approx(0.37817, abs=SIGMA_TOL)
    assert sy == pytest.approx(0.17809, abs=SIGMA_TOL)
    assert adj.drms_m == pytest.approx(0.41801, abs=SIGMA_TOL)


def test_benning_example_8_8_trilateration() -> None:
    """Benning (2011), Statistik in Geodäsie, Geoinformation und Bauwesen, Wichmann,
    Ex. 8-8, pp. 285–291: five distances (σ 0.02 m) from point 6 to fixed points 1–5.
    Published (Krumm .adj): 6 = (2000.0000, 1999.9976), σ 0.504 / 0.996 cm, σp 1.116 cm."""
    stations = np.array([[3000.0, 2000.0], [1000.0, 2000.0], [3000.0, 2100.0],
                         [1000.0, 2100.0], [2000.0, 1000.0]])
    obs = np.array([1000.00, 1000.00, 1005.00, 1005.00, 1000.00])
    C = np.eye(5) * 0.02**2

    def lin(x: np.ndarray) -> Linearisation:
        d = x[None, :] - stations
        r = np.linalg.norm(d, axis=1)
        return Linearisation(d / r[:, None], obs - r, C)

    adj = gauss_newton(lin, np.array([2000.0, 2000.0]), np.ones(5, bool), epsilon=1e-6,
                       scale_vcv=True)
    assert adj.ok and adj.category == "IV"
    assert adj.x[0] == pytest.approx(2000.0000, abs=COORD_TOL)
    assert adj.x[1] == pytest.approx(1999.9976, abs=COORD_TOL)
    sx, sy = np.sqrt(np.diag(adj.cov_x))
    assert sx == pytest.approx(0.00504, abs=SIGMA_TOL)
    assert sy == pytest.approx(0.00996, abs=SIGMA_TOL)
    assert adj.drms_m == pytest.approx(0.01116, abs=SIGMA_TOL)
