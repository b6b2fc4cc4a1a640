"""The engine's hot-path shortcuts (issue 7) give exactly what the general code they replace gives.

Each test compares a shortcut with an independent reference: numpy/LAPACK for the linear algebra,
the general routine it specialises (Clenshaw with derivative, the grid inversion inside the Decca
geometry), or the rule it implements written out plainly (the ``.OUT`` quoting rule, argmax).
Equality is exact (``==``, ``array_equal``) where the shortcut performs the same floating-point
operations; a tolerance is stated where it does not.
"""

from __future__ import annotations

import cmath
import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine.filter.kalman as kf
from engine.geodesy.ellipsoidal import GeodesicSolver
from engine.geodesy.tmgrid import TMGrid, _clenshaw, _clenshaw_sum
from engine.io.datumfile import read_datum_file
from engine.io.deccafile import read_chain_file
from engine.io.outlog import _NEEDS_QUOTES, format_value
from engine.lsq.confidence import eigenvalues_2x2, error_ellipse
from engine.lsq.snooping import _worst
from engine.systems.decca import decca_geometry, decca_vcv_lanes, decca_vcv_m2, place_chain
from tests.paths import DATA

ED50 = read_datum_file(DATA / "TO_WGS84.DAT").datum("ED50")
GRID = TMGrid(ED50.ellipsoid, 5.0)
GEOD = GeodesicSolver(ED50.ellipsoid)


# --------------------------------------------------------------------------- .OUT values


@pytest.mark.parametrize(("value", "text"), [
    (0.1, "0.1"),
    (np.float64(0.1), "0.1"),  # a numpy float writes like a Python float, not "np.float64(…)"
    (-0.0, "-0.0"),
    (math.nan, "nan"),
    (np.float64(math.nan), "nan"),
    (-math.inf, "-inf"),
    (7, "7"),
    (np.int64(-7), "-7"),
    (True, "1"),
    (False, "0"),
    (None, "-"),
    ("ED50", "ED50"),
    ("", '""'),
    ("-", '"-"'),
    ("a b", '"a b"'),
    ("1e5", '"1e5"'),  # a bare word that reads back as a number is quoted
    ("\u0661\u0662", '"\u0661\u0662"'),  # Arabic-Indic digits: float() reads them
    ("x\u2003y", '"x\u2003y"'),  # an em space is a blank (str.isspace)
    ('say "hi"', '"say \\"hi\\""'),
])
def test_format_value_by_type(value: object, text: str) -> None:
    assert format_value(value) == text  # type: ignore[arg-type]


@given(st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=20))
def test_quoting_pattern_is_the_isspace_rule(text: str) -> None:
    """The compiled pattern flags exactly the words the plain rule flags: a character with
    ``str.isspace()``, a quote, ``=`` or a backslash."""
    plain = any(c.isspace() or c in '"=\\' for c in text)
    assert (_NEEDS_QUOTES(text) is not None) is plain


# --------------------------------------------------------------------------- linear algebra


@settings(deadline=None)
@given(st.floats(0.0, 1e8), st.floats(-1e8, 1e8), st.floats(0.0, 1e8))
def test_eigenvalues_2x2_match_eigvalsh(sxx: float, sxy: float, syy: float) -> None:
    """Closed form against LAPACK's symmetric eigensolver; 1e-9 of the largest magnitude
    (the closed form loses relative accuracy in λ2 when λ2 ≪ λ1, both are backward stable)."""
    l1, l2 = eigenvalues_2x2(sxx, sxy, syy)
    lam = np.linalg.eigvalsh(np.array([[sxx, sxy], [sxy, syy]]))
    scale = max(abs(sxx), abs(sxy), abs(syy), 1e-300)
    assert l1 == pytest.approx(lam[1], abs=1e-9 * scale)
    assert l2 == pytest.approx(lam[0], abs=1e-9 * scale)
    assert l1 >= l2


def test_isotropic_ellipse_points_east() -> None:
    e = error_ellipse(np.eye(2) * 4.0)
    assert (e.a_m, e.b_m, e.az_deg, e.phi_deg) == (2.0, 2.0, 90.0, 0.0)


# --------------------------------------------------------------------------- w-test helpers


def _fake(w: list[float]) -> SimpleNamespace:
    return SimpleNamespace(w=np.array(w))


@pytest.mark.parametrize("w", [
    [math.nan, 1.0, -3.0, 3.0, math.nan],
    [0.5, -0.5, 0.5],
    [math.nan, math.nan],
    [2.0, math.nan, -2.5, 2.5, 0.1],
])
def test_worst_is_the_first_largest_abs_w_ignoring_nan(w: list[float]) -> None:
    """Reference: the former numpy form, NaN replaced by −1 and the first argmax taken."""
    aw = np.abs(np.array(w))
    aw[np.isnan(aw)] = -1.0
    k = int(aw.argmax())
    slot, value = _worst(_fake(w))  # type: ignore[arg-type]
    assert slot == k
    assert value == w[k] or (math.isnan(value) and math.isnan(w[k]))


# --------------------------------------------------------------------------- TM grid


@given(st.floats(-1.0, 1.0), st.floats(-0.05, 0.05))
def test_clenshaw_sum_equals_the_general_sum(xi: float, eta: float) -> None:
    """The sum without its derivative is the same recurrence: equal to the last bit."""
    z = complex(xi, eta)
    s2, c2 = cmath.sin(2.0 * z), cmath.cos(2.0 * z)
    assert _clenshaw_sum(GRID._alpha, s2, c2) == _clenshaw(GRID._alpha, s2, c2)[0]
    assert _clenshaw_sum(GRID._beta, s2, c2) == _clenshaw(GRID._beta, s2, c2)[0]


@given(st.floats(50.0, 56.0), st.floats(2.0, 8.0))
def test_forward_equals_forward_full(lat: float, lon: float) -> None:
    """The position-only forward and the one with convergence and scale agree exactly, and the
    inverse (with the inlined conformal-latitude Newton) returns the point to 1e-9°
    (≈ 0.1 mm; the series and the Newton stop are accurate to nanometres near the CM)."""
    x, y = GRID.forward(lat, lon)
    assert (x, y) == GRID.forward_full(lat, lon)[:2]
    la, lo = GRID.inverse(x, y)
    assert la == pytest.approx(lat, abs=1e-9) and lo == pytest.approx(lon, abs=1e-9)


# --------------------------------------------------------------------------- Decca geometry


def _placed() -> object:
    return place_chain(read_chain_file(DATA / "DECCA.CHN")["9B"], GRID)


def test_decca_geometry_with_a_known_position_is_the_same() -> None:
    """Passing the point's (lat, lon) skips one grid inversion and changes nothing."""
    placed = _placed()
    for x, y in ((-31615.4, 5857300.2), (-40000.0, 5870000.0), (10000.0, 5830000.0)):
        a = decca_geometry(placed, x, y, GEOD)  # type: ignore[arg-type]
        b = decca_geometry(placed, x, y, GEOD, GRID.inverse(x, y))  # type: ignore[arg-type]
        for name in a.__slots__:
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_decca_vcv_in_metres_is_lanes_times_k_k() -> None:
    """C_ij(m²) = C_ij(lanes²)·k_i·k_j (A4.4), the numpy outer product as reference."""
    geom = decca_geometry(_placed(), -31615.4, 5857300.2, GEOD)  # type: ignore[arg-type]
    k = geom.metres_per_lane
    np.testing.assert_array_equal(decca_vcv_m2(geom, 64.0),
                                  decca_vcv_lanes(geom, 64.0) * np.outer(k, k))


# --------------------------------------------------------------------------- filter


def test_ls_statistics_are_computed_once_and_read_only() -> None:
    p = kf.FilterParams()
    s = kf.init_state(0.0, 0.0, 0.0, 0.0, 6.0, 0.5, 0.0, 0.0, 0.0, p)
    r = kf.update(s, kf.sensor_measurement(s, log_ms=6.5, gyro_grid_rad=0.52, params=p), p)
    t = r.ls.t
    assert t is r.ls.t and not t.flags.writeable
    S_inv = np.linalg.inv(r.S)
    np.testing.assert_allclose(t, S_inv @ r.innovation / np.sqrt(np.diag(S_inv)), rtol=1e-12)


def test_stacked_priors_of_two_parts_are_block_diagonal() -> None:
    """Fix-error keys from two blocks: each keeps its own prior, no covariance between them."""
    a = kf.lop_measurement(np.array([[1.0, 0.0]]), np.array([0.0]), np.zeros(2),
                           np.array([[4.0]]), fix_keys=("b1",), bias_cov=np.array([[9.0]]),
                           bias_tau_s=(100.0,))
    b = kf.lse_measurement(1.0, 2.0, np.array([[100.0, 20.0], [20.0, 50.0]]),
                           kf.FilterParams(coloured=True))
    m = kf.stack_measurements(a, b)
    assert m.bias_keys == ("b1", "fix_e", "fix_n")
    expected = np.zeros((3, 3))
    expected[0, 0] = 9.0
    expected[1:, 1:] = b.bias_cov
    np.testing.assert_array_equal(m.bias_cov, expected)
    assert m.bias_tau_s == (100.0, 240.0, 240.0)
