"""The braille canvas (uvnav_tui/widgets/canvas.py): dots, world mapping, lines, circles, ellipses,
text, the scale bar and the charts."""

from __future__ import annotations

import math

import pytest

from uvnav_tui.widgets.canvas import (
    DASHED,
    BrailleCanvas,
    Series,
    braille_char,
    chart_lines,
    draw_series,
    format_distance,
    nice_length,
    nice_step,
    ticks,
)


def _dots(cv: BrailleCanvas) -> list[tuple[int, int]]:
    return [(u, v) for v in range(cv.dot_height) for u in range(cv.dot_width) if cv.is_set(u, v)]


def test_braille_dot_bits() -> None:
    """Dot (0,0) is braille dot 1 (U+2801), (1,3) dot 8 (U+2880); an empty cell is a space."""
    cv = BrailleCanvas(2, 1, (0.0, 4.0), (0.0, 4.0))
    cv.dot(0, 0)
    cv.dot(3, 3)
    assert cv.lines() == ["\u2801\u2880"]
    assert braille_char(0) == " "
    assert braille_char(0xFF) == "⣿"


def test_map_view_is_north_up_with_equal_scale() -> None:
    """40×20 cells, ±2000 m across: 50 m per dot both ways, so ±2000 m down too (80 dots)."""
    cv = BrailleCanvas.map_view(40, 20, (1000.0, 5_000_000.0), 2000.0)
    assert cv.units_per_dot == pytest.approx((50.0, 50.0))
    assert cv.x_range == pytest.approx((-1000.0, 3000.0))
    assert cv.y_range == pytest.approx((4_998_000.0, 5_002_000.0))
    # north is up: a point north of the centre is in a lower row number
    assert cv.to_cell(1000.0, 5_001_000.0)[1] < cv.to_cell(1000.0, 4_999_000.0)[1]
    assert cv.to_cell(1000.0, 5_000_000.0) == (20, 10)
    assert cv.contains(2999.0, 5_000_000.0) and not cv.contains(3001.0, 5_000_000.0)


def test_map_view_aspect_follows_the_cells() -> None:
    """A 60×10 canvas at ±3000 m: 50 m per dot, so only ±1000 m down."""
    cv = BrailleCanvas.map_view(60, 10, (0.0, 0.0), 3000.0)
    assert cv.y_range == pytest.approx((-1000.0, 1000.0))


def test_line_end_cells() -> None:
    """One world unit per dot: a diagonal from the top-left dot to the bottom-right dot starts
    in cell (0, 0) and ends in cell (9, 4), with one dot per step."""
    cv = BrailleCanvas(10, 5, (0.0, 20.0), (0.0, 20.0))
    cv.line(0.5, 19.5, 19.5, 0.5)
    assert cv.is_set(0, 0) and cv.is_set(19, 19)
    assert cv.to_cell(0.5, 19.5) == (0, 0) and cv.to_cell(19.5, 0.5) == (9, 4)
    text = cv.lines()
    assert text[0][0] != " " and text[4][9] != " "
    assert len(_dots(cv)) == 20
    assert all(u == v for u, v in _dots(cv))


def test_points_on_the_range_edges_are_drawn() -> None:
    """x = x_max and y = y_min belong to the last dot (a chart's latest value at t = 0)."""
    cv = BrailleCanvas(2, 1, (-4.0, 0.0), (0.0, 4.0))
    cv.point(0.0, 0.0)
    cv.point(-4.0, 4.0)
    cv.point(0.1, 2.0)
    assert _dots(cv) == [(0, 0), (3, 3)]


def test_horizontal_line_is_a_row_of_top_dots() -> None:
    cv = BrailleCanvas(5, 2, (0.0, 10.0), (0.0, 8.0))
    cv.line(0.0, 7.5, 9.99, 7.5)
    assert cv.lines() == ["⠉⠉⠉⠉⠉", "     "]


def test_lines_are_clipped() -> None:
    """A line far off the canvas draws nothing; a very long one crossing it draws edge to edge
    (and quickly: only the visible part is stepped)."""
    cv = BrailleCanvas(10, 5, (0.0, 20.0), (0.0, 20.0))
    cv.line(100.0, 100.0, 200.0, 300.0)
    assert _dots(cv) == []
    cv.line(-1e9, 10.2, 1e9, 10.2)
    dots = _dots(cv)
    assert len(dots) == 20
    assert {u for u, _ in dots} == set(range(20))


def test_dashed_line_has_gaps() -> None:
    """(3 on, 2 off) over 40 dots: 24 dots set."""
    solid = BrailleCanvas(20, 1, (0.0, 40.0), (0.0, 4.0))
    solid.line(0.5, 2.0, 39.5, 2.0)
    dashed = BrailleCanvas(20, 1, (0.0, 40.0), (0.0, 4.0))
    dashed.line(0.5, 2.0, 39.5, 2.0, dash=DASHED)
    assert len(_dots(solid)) == 40
    assert len(_dots(dashed)) == 24
    assert [dashed.is_set(u, 2) for u in range(5)] == [True, True, True, False, False]


def test_circle_extent() -> None:
    """r = 1000 m at 50 m per dot: 20 dots each way from the centre dot (40, 40)."""
    cv = BrailleCanvas.map_view(40, 20, (0.0, 0.0), 2000.0)
    cv.circle(0.0, 0.0, 1000.0)
    dots = _dots(cv)
    us = [u for u, _ in dots]
    vs = [v for _, v in dots]
    assert min(us) in (19, 20) and max(us) in (59, 60)
    assert min(vs) in (19, 20) and max(vs) in (59, 60)
    assert all(abs(math.hypot(u + 0.5 - 40.0, v + 0.5 - 40.0) - 20.0) < 1.5 for u, v in dots)


def test_ellipse_orientation_112_points_ese() -> None:
    """A 112° major axis (Pg 840's sample) points east-south-east: the dot farthest from the
    centre on the east side lies at azimuth ≈ 112°, south of the centre."""
    cv = BrailleCanvas.map_view(40, 20, (0.0, 0.0), 2000.0)
    cv.ellipse(0.0, 0.0, 1500.0, 300.0, 112.0)
    east = [(u, v) for u, v in _dots(cv) if u >= 40]
    u, v = max(east, key=lambda p: math.hypot(p[0] + 0.5 - 40.0, p[1] + 0.5 - 40.0))
    de, dn = (u + 0.5 - 40.0), -(v + 0.5 - 40.0)
    assert math.degrees(math.atan2(de, dn)) == pytest.approx(112.0, abs=3.0)
    assert dn < 0.0  # south of the centre
    assert math.hypot(de, dn) == pytest.approx(30.0, abs=1.5)  # 1500 m / 50 m per dot


def test_ellipse_minor_axis() -> None:
    """Az 0°: major axis north–south (±30 dots), minor east–west (±6 dots)."""
    cv = BrailleCanvas.map_view(40, 20, (0.0, 0.0), 2000.0)
    cv.ellipse(0.0, 0.0, 1500.0, 300.0, 0.0)
    dots = _dots(cv)
    assert max(u for u, _ in dots) - min(u for u, _ in dots) in (11, 12, 13)
    assert max(v for _, v in dots) - min(v for _, v in dots) in (59, 60, 61)


def test_markers_text_and_labels() -> None:
    """Text replaces the braille of its cells and is clipped at the edges; a label goes right
    of its point, or left if it would not fit; off-canvas markers are refused."""
    cv = BrailleCanvas(10, 3, (0.0, 10.0), (0.0, 6.0))
    cv.line(0.0, 3.0, 9.99, 3.0)
    assert cv.marker(5.0, 3.0, "M")
    assert not cv.marker(50.0, 3.0, "X")
    cv.label(1.0, 5.5, "AB")
    cv.label(9.5, 0.5, "LONG")
    cv.text(8, 1, "CUT")
    rows = cv.lines()
    assert all(len(r) == 10 for r in rows)
    assert rows[0][2:4] == "AB"
    assert rows[2][5:9] == "LONG"
    assert rows[1][5] == "M" and rows[1][8:] == "CU"
    assert rows[1][:5] == "⠤⠤⠤⠤⠤"


def test_scale_bar() -> None:
    """1000 m at 50 m per dot: a 20-dot bar (from dot 2 to 22) in the last row, then its label."""
    cv = BrailleCanvas.map_view(40, 20, (0.0, 0.0), 2000.0)
    cv.scale_bar(1000.0, "1000 m")
    bar = [u for u in range(cv.dot_width) if cv.is_set(u, 4 * 19 + 2)]
    assert bar[0] == 2 and bar[-1] == 22
    assert cv.lines()[-1].rstrip().endswith("1000 m")


def test_nice_numbers_and_labels() -> None:
    assert nice_length(1000.0) == 1000.0
    assert nice_length(999.0) == 500.0
    assert nice_length(15_000.0) == 10_000.0
    assert nice_length(0.3) == pytest.approx(0.2)
    assert nice_step(43.0, 1) == 50.0
    assert nice_step(50.0, 5) == 10.0
    assert ticks(-43.0, 43.0, 20.0) == [-40.0, -20.0, 0.0, 20.0, 40.0]
    assert format_distance(1000.0) == "1000 m"
    assert format_distance(20_000.0) == "20 km"
    with pytest.raises(ValueError):
        nice_length(0.0)


def test_dense_series_draws_the_same_dots_as_the_plain_polyline() -> None:
    """The per-column envelope used for long runs changes nothing on screen."""
    pts = [(i / 100.0, math.sin(i / 7.0) * 3.0 + (i % 13) / 5.0) for i in range(3000)]
    a = BrailleCanvas(30, 6, (0.0, 30.0), (-4.0, 6.0))
    draw_series(a, Series(pts))
    b = BrailleCanvas(30, 6, (0.0, 30.0), (-4.0, 6.0))
    b.polyline(pts)
    assert a.lines() == b.lines()


def test_series_gaps_and_scatter() -> None:
    """A NaN or an x step over max_gap breaks the line; join=False draws lone dots."""
    cv = BrailleCanvas(10, 1, (0.0, 20.0), (0.0, 4.0))
    draw_series(cv, Series([(0.5, 2.0), (5.5, 2.0), (15.5, 2.0), (19.5, 2.0)], max_gap=6.0))
    assert [cv.is_set(u, 2) for u in (0, 3, 5, 10, 15, 17, 19)] == [True] * 3 + [False] + [True] * 3
    sc = BrailleCanvas(10, 1, (0.0, 20.0), (0.0, 4.0))
    draw_series(sc, Series([(0.5, 2.0), (5.5, 2.0), (9.5, math.nan)], join=False))
    assert len(_dots(sc)) == 2


def test_chart_layout() -> None:
    """Exact size; y tick labels with ┤; the x axis with ┬ ticks and their labels; a dotted
    zero line; without the x axis only the plot rows."""
    pts = [(x / 10.0, x / 10.0) for x in range(-50, 1)]
    rows = chart_lines(40, 8, [Series(pts)], (-5.0, 0.0), (-5.0, 5.0), zero_line=True,
                       x_step=1.0)
    assert len(rows) == 8 and all(len(r) == 40 for r in rows)
    assert rows[0].startswith("      5┤")
    assert any(r.startswith("      0┤") for r in rows)
    assert rows[-2].startswith("       └") and "┬" in rows[-2]
    assert rows[-1].split() == ["-5", "-4", "-3", "-2", "-1", "0"]
    auto = chart_lines(40, 8, [Series(pts)], (-5.0, 0.0), (-5.0, 5.0))
    assert auto[-1].split() == ["-4", "-2", "0"]  # at most one tick per 8 columns
    bare = chart_lines(40, 5, [Series(pts)], (-5.0, 0.0), (-5.0, 5.0), x_axis=False)
    assert len(bare) == 5 and not any("└" in r for r in bare)
    with pytest.raises(ValueError):
        chart_lines(8, 2, [], (0.0, 1.0), (0.0, 1.0))
