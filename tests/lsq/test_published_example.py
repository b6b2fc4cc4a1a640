"""Published single-point adjustments reproduced to their published coordinates.

Source actually read (not the books themselves): the example files of F. Krumm, "Geodetic
Network Adjustment Examples", Geodätisches Institut, Universität Stuttgart, Rev. 3.5
(20 January 2020), in the copy distributed with GNU Gama: each ``*.dat`` holds the book's data,
each ``*.adj`` "the adjusted coordinates, as published by Friedhelm Krumm" (GNU Gama README of
that directory). Files read: ``2D/Ghilani15_5_Angle_fix.{dat,adj}``,
``2D/Ghilani15_4_Angle_fix.{dat,adj}``, ``2D/Benning88_Distance_fix.{dat,adj}``,
``2D/Carosio_DistanceDirection_fix.{dat,adj}``, ``2D/Benning83_DistanceDirection_fix.{dat,adj}``
(vendored at github.com/kauevestena/geocomp, tests/data/krumm/2D/). The ``.adj`` rows are
``name x dx[cm] σx[cm] y dy[cm] σy[cm] σp[cm]``; σ are a posteriori (σ̂0² = S² scaling).
The direction examples carry one orientation unknown per instrument station, in radians next to
coordinates in metres: they exercise the core with u = 6 and 7 and mixed observation types.

Coordinates: x = East, y = North; azimuths from North clockwise (Ghilani's convention, which
reproduces the observed angles from the given coordinates). Angles in gon as in Krumm's files.
Tolerance = the published rounding: coordinates 4 dp → ±0.05 mm; σ 3 dp in cm → ±0.005 mm.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from engine.lsq.adjustment import Linearisation, gauss_newton

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


def _network_model(fixed: dict[str, tuple[float, float]], unknown: list[str],
                   stations: list[str], directions: list[tuple[str, str, float]],
                   distances: list[tuple[str, str, float]], sd_dir_gon: float,
                   sd_dist_m: float) -> Callable[[np.ndarray], Linearisation]:
    """Directions r_ij = t_ij − o_i (gon) and distances s_ij (m) with unknown points
    ``unknown`` and one orientation unknown o_i per instrument station in ``stations``.

    Parameters: (x, y) of each unknown point [m], then the orientations [rad]. Rows: directions
    in rad per parameter unit (C_l in rad²), distances in m/m (C_l in m²).
    """
    n_dir = len(directions)
    C = np.diag([(sd_dir_gon * GON) ** 2] * n_dir + [sd_dist_m**2] * len(distances))
    n_pt = 2 * len(unknown)

    def lin(p: np.ndarray) -> Linearisation:
        P = {k: np.asarray(v, dtype=float) for k, v in fixed.items()}
        for i, name in enumerate(unknown):
            P[name] = p[2 * i:2 * i + 2]
        A = np.zeros((C.shape[0], p.size))
        b = np.zeros(C.shape[0])
        for k, (st, to, val) in enumerate(directions):
            t, g = _az(P[st], P[to])
            o = p[n_pt + stations.index(st)]
            b[k] = (val * GON - (t - o) + math.pi) % (2.0 * math.pi) - math.pi
            if to in unknown:
                A[k, 2 * unknown.index(to):2 * unknown.index(to) + 2] += g
            if st in unknown:
                A[k, 2 * unknown.index(st):2 * unknown.index(st) + 2] -= g
            A[k, n_pt + stations.index(st)] = -1.0
        for m, (st, to, val) in enumerate(distances):
            k = n_dir + m
            d = P[to] - P[st]
            r = float(np.hypot(*d))
            b[k] = val - r
            if to in unknown:
                A[k, 2 * unknown.index(to):2 * unknown.index(to) + 2] += d / r
            if st in unknown:
                A[k, 2 * unknown.index(st):2 * unknown.index(st) + 2] -= d / r
        return Linearisation(A, b, C)

    return lin


def test_carosio_distance_direction_point() -> None:
    """Carosio (1983), Verfahren der multivariaten Statistik zur Beurteilung der Resultate und
    der Zuverlässigkeit geodätischer Messsysteme, IGP ETH Zürich, Mitteilungen Nr. 35,
    pp. 65–71: one new point B from the fixed A, P, C — three distances from B (σ 1 cm), ten
    directions (σ 0.005 gon) observed at B and at A, P, C, each station with its own
    orientation unknown (u = 2 + 4 = 6, n = 13, r = 7).
    Published (Krumm .adj): B = (99.9997, 1000.0098), corrections −0.028 / +0.978 cm from the
    approximate (100, 1000), σ 0.001 / 0.001 cm, σp 0.002 cm (the observations fit to a few
    0.1 mm, so S² is tiny and the a posteriori σ are µm)."""
    fixed = {"A": (-1000.0, 100.0), "C": (1000.0, 100.0), "P": (100.0, 0.0)}
    directions = [("B", "A", 256.34476), ("B", "P", 199.99998), ("B", "C", 150.00034),
                  ("P", "B", 399.99998), ("P", "C", 92.95534), ("P", "A", 305.77159),
                  ("A", "B", 56.34476), ("A", "P", 105.77159),
                  ("C", "P", 292.95534), ("C", "B", 350.00034)]
    distances = [("B", "A", 1421.2730), ("B", "P", 1000.0098), ("B", "C", 1272.7993)]
    lin = _network_model(fixed, ["B"], ["B", "P", "A", "C"], directions, distances,
                         0.005, 0.01)
    x0 = np.array([100.0, 1000.0, 0.0, 0.0, 0.0, 0.0])  # orientations start at 0
    adj = gauss_newton(lin, x0, np.ones(13, bool), epsilon=1e-9, scale_vcv=True)
    assert adj.ok and adj.u == 6 and adj.redundancy == 7
    assert adj.x[0] == pytest.approx(99.9997, abs=COORD_TOL)
    assert adj.x[1] == pytest.approx(1000.0098, abs=COORD_TOL)
    assert (adj.x[:2] - x0[:2]) * 100.0 == pytest.approx([-0.028, 0.978], abs=0.0005)
    sx, sy = np.sqrt(np.diag(adj.cov_x))[:2]
    assert sx == pytest.approx(0.00001, abs=SIGMA_TOL)
    assert sy == pytest.approx(0.00001, abs=SIGMA_TOL)
    assert math.hypot(sx, sy) == pytest.approx(0.00002, abs=SIGMA_TOL)
    assert float(np.nansum(adj.redundancy_numbers)) == pytest.approx(7.0, abs=1e-9)


def test_benning_example_8_3_distance_direction_network() -> None:
    """Benning (2011), Statistik in Geodäsie, Geoinformation und Bauwesen, Wichmann, Ex. 8-3,
    p. 258: new points 3 and 4 from the fixed 1 (0, 1000) and 2 (1000, 1000); seven directions
    at 1, 2, 3 (σ 0.001 gon, one orientation unknown per station, approximations 150, 200,
    0 gon) and five distances (σ 1 cm): u = 4 + 3 = 7, n = 12, r = 5.
    Published (Krumm .adj): 3 = (−0.0101, −0.0231), corrections −1.009 / −2.314 cm,
    σ 0.563 / 0.409 cm, σp 0.695 cm; 4 = (999.9904, 0.0163), −0.959 / +1.633 cm,
    σ 0.570 / 0.395 cm, σp 0.694 cm."""
    fixed = {"1": (0.0, 1000.0), "2": (1000.0, 1000.0)}
    directions = [("1", "3", 50.001), ("1", "4", 0.000), ("2", "3", 49.998), ("2", "4", 0.000),
                  ("3", "1", 0.000), ("3", "2", 49.999), ("3", "4", 99.997)]
    distances = [("1", "3", 1000.02), ("1", "4", 1414.20), ("2", "3", 1414.24),
                 ("2", "4", 999.98), ("3", "4", 1000.00)]
    lin = _network_model(fixed, ["3", "4"], ["1", "2", "3"], directions, distances, 0.001, 0.01)
    x0 = np.array([0.0, 0.0, 1000.0, 0.0, 150.0 * GON, 200.0 * GON, 0.0])
    adj = gauss_newton(lin, x0, np.ones(12, bool), epsilon=1e-9, scale_vcv=True)
    assert adj.ok and adj.u == 7 and adj.redundancy == 5
    published = {  # x, y [m]; corrections dx, dy [cm]; σx, σy, σp [cm]
        0: (-0.0101, -0.0231, -1.009, -2.314, 0.563, 0.409, 0.695),
        2: (999.9904, 0.0163, -0.959, 1.633, 0.570, 0.395, 0.694),
    }
    sd = np.sqrt(np.diag(adj.cov_x))
    for i, (x, y, dx, dy, sx, sy, sp) in published.items():
        assert adj.x[i] == pytest.approx(x, abs=COORD_TOL)
        assert adj.x[i + 1] == pytest.approx(y, abs=COORD_TOL)
        assert (adj.x[i:i + 2] - x0[i:i + 2]) * 100.0 == pytest.approx([dx, dy], abs=0.0005)
        assert sd[i] == pytest.approx(sx / 100.0, abs=SIGMA_TOL)
        assert sd[i + 1] == pytest.approx(sy / 100.0, abs=SIGMA_TOL)
        assert math.hypot(sd[i], sd[i + 1]) == pytest.approx(sp / 100.0, abs=SIGMA_TOL)
