"""A braille/box plotting canvas for the console's plots (Pg 642 position plot, Pg 643 History).

Pure text: every function returns strings, nothing here touches Textual.  A character cell holds
a 2 × 4 braille dot matrix (U+2800 block), so a cell of a terminal font (about twice as high as
wide) holds dots that are about square: equal scale on both axes is equal metres per dot.

Coordinates: *world* x to the right and y up (for a map: x east, y north in grid metres, north
up); *dots* u (column, 0 at the left) and v (row, 0 at the top), ``2·width`` × ``4·height``;
*cells* (col, row), ``width`` × ``height``.  Text drawn on the canvas (markers, labels, the scale
bar's label) replaces the braille of its cells.  Empty cells are spaces.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

BRAILLE_BASE = 0x2800
_BITS = ((0x01, 0x08), (0x02, 0x10), (0x04, 0x20), (0x40, 0x80))
"""Braille dot bit of dot row ``r`` (0–3) and column ``c`` (0–1) of a cell: ``_BITS[r][c]``."""

Dash = tuple[int, int]
"""A dash pattern: ``(on, off)`` lengths in dots along the path."""
DASHED: Dash = (3, 2)
DOTTED: Dash = (1, 2)

Point = tuple[float, float]


def braille_char(bits: int) -> str:
    """The braille character of a dot mask (0 → a space, for legibility and clean dumps)."""
    return chr(BRAILLE_BASE + bits) if bits else " "


def nice_length(limit: float) -> float:
    """The largest 1, 2 or 5 × 10ⁿ not above ``limit`` (> 0): a scale bar or tick length."""
    if not (limit > 0.0 and math.isfinite(limit)):
        raise ValueError(f"nice_length: limit must be positive and finite, got {limit}")
    exp = math.floor(math.log10(limit))
    for m in (5.0, 2.0, 1.0):
        v = m * 10.0**exp
        if v <= limit * (1.0 + 1e-12):
            return v
    return 10.0 ** (exp - 1) * 5.0  # pragma: no cover - unreachable (1·10ⁿ ≤ limit)


def nice_step(span: float, max_ticks: int) -> float:
    """The smallest 1, 2 or 5 × 10ⁿ step giving at most ``max_ticks`` intervals over ``span``."""
    if not (span > 0.0 and math.isfinite(span)):
        raise ValueError(f"nice_step: span must be positive and finite, got {span}")
    raw = span / max(1, max_ticks)
    exp = math.floor(math.log10(raw))
    for m in (1.0, 2.0, 5.0, 10.0):
        v = m * 10.0**exp
        if v >= raw * (1.0 - 1e-12):
            return v
    return 10.0 ** (exp + 1)  # pragma: no cover


def ticks(lo: float, hi: float, step: float) -> list[float]:
    """Multiples of ``step`` in [lo, hi] (ascending; −0.0 normalised to 0.0)."""
    first = math.ceil(lo / step - 1e-9)
    last = math.floor(hi / step + 1e-9)
    return [k * step + 0.0 for k in range(first, last + 1)]


def format_distance(metres: float) -> str:
    """``250 m``, ``1000 m``, ``20 km``: a distance label (km from 10 km on)."""
    if abs(metres) >= 10_000.0:
        return f"{metres / 1000.0:g} km"
    return f"{metres:g} m"


class BrailleCanvas:
    """``width`` × ``height`` cells showing world ``x_range`` × ``y_range`` (x right, y up).

    Use :meth:`map_view` for a north-up map with equal scale on both axes.
    """

    def __init__(self, width: int, height: int, x_range: tuple[float, float],
                 y_range: tuple[float, float]) -> None:
        if width < 1 or height < 1:
            raise ValueError(f"canvas needs at least 1×1 cells, got {width}×{height}")
        (x0, x1), (y0, y1) = x_range, y_range
        if not all(math.isfinite(v) for v in (x0, x1, y0, y1)) or x1 <= x0 or y1 <= y0:
            raise ValueError(f"canvas ranges must be finite and increasing: {x_range} {y_range}")
        self.width = width
        self.height = height
        self.x_range = (float(x0), float(x1))
        self.y_range = (float(y0), float(y1))
        self._sx = 2.0 * width / (x1 - x0)
        self._sy = 4.0 * height / (y1 - y0)
        self._bits = [0] * (width * height)
        self._text: dict[tuple[int, int], str] = {}

    @classmethod
    def map_view(cls, width: int, height: int, centre: Point,
                 half_width_m: float) -> BrailleCanvas:
        """North-up map centred on ``centre`` (grid m, x east, y north) spanning
        ``centre.x ± half_width_m`` across; the height follows from equal metres per dot."""
        if not (half_width_m > 0.0 and math.isfinite(half_width_m)):
            raise ValueError(f"map_view: half width must be positive, got {half_width_m}")
        cx, cy = centre
        per_dot = half_width_m / width
        half_h = 2.0 * height * per_dot
        return cls(width, height, (cx - half_width_m, cx + half_width_m),
                   (cy - half_h, cy + half_h))

    # ------------------------------------------------------------------ geometry
    @property
    def dot_width(self) -> int:
        """Dots across (2 per cell)."""
        return 2 * self.width

    @property
    def dot_height(self) -> int:
        """Dots down (4 per cell)."""
        return 4 * self.height

    @property
    def units_per_dot(self) -> tuple[float, float]:
        """World units (m on a map) per dot, across and down."""
        return 1.0 / self._sx, 1.0 / self._sy

    def to_dot(self, x: float, y: float) -> tuple[float, float]:
        """World → continuous dot coordinates (u right, v down); dot (i, j) covers
        [i, i+1) × [j, j+1)."""
        return (x - self.x_range[0]) * self._sx, (self.y_range[1] - y) * self._sy

    def to_cell(self, x: float, y: float) -> tuple[int, int]:
        """World → cell (col, row); may lie outside the canvas."""
        u, v = self.to_dot(x, y)
        return math.floor(u / 2.0), math.floor(v / 4.0)

    def contains(self, x: float, y: float) -> bool:
        """True if the world point falls on the canvas."""
        u, v = self.to_dot(x, y)
        return 0.0 <= u < self.dot_width and 0.0 <= v < self.dot_height

    # ------------------------------------------------------------------ dots
    def dot(self, u: int, v: int) -> None:
        """Set dot (u, v); dots off the canvas are ignored."""
        if 0 <= u < self.dot_width and 0 <= v < self.dot_height:
            self._bits[(v >> 2) * self.width + (u >> 1)] |= _BITS[v & 3][u & 1]

    def is_set(self, u: int, v: int) -> bool:
        """True if dot (u, v) is set."""
        if not (0 <= u < self.dot_width and 0 <= v < self.dot_height):
            return False
        return bool(self._bits[(v >> 2) * self.width + (u >> 1)] & _BITS[v & 3][u & 1])

    def point(self, x: float, y: float) -> None:
        """One dot at a world point (ignored when off the canvas or not finite).  A point on the
        right or bottom edge of the range (x = x_max, y = y_min) gets the last dot."""
        if math.isfinite(x) and math.isfinite(y):
            u, v = self.to_dot(x, y)
            if 0.0 <= u <= self.dot_width and 0.0 <= v <= self.dot_height:
                self.dot(min(int(u), self.dot_width - 1), min(int(v), self.dot_height - 1))

    def _clip(self, u0: float, v0: float, u1: float, v1: float
              ) -> tuple[float, float] | None:
        """Liang–Barsky: the parameter interval [t0, t1] of the segment on the canvas."""
        t0, t1 = 0.0, 1.0
        du, dv = u1 - u0, v1 - v0
        hi_u = self.dot_width - 1e-9
        hi_v = self.dot_height - 1e-9
        for p, q in ((-du, u0), (du, hi_u - u0), (-dv, v0), (dv, hi_v - v0)):
            if p == 0.0:
                if q < 0.0:
                    return None
                continue
            r = q / p
            if p < 0.0:
                if r > t1:
                    return None
                t0 = max(t0, r)
            else:
                if r < t0:
                    return None
                t1 = min(t1, r)
        return t0, t1

    def _segment(self, a: Point, b: Point, dash: Dash | None, phase: int,
                 skip_first: bool) -> int:
        """Draw dot-space segment a → b (DDA, one dot per step); returns the new dash phase."""
        u0, v0 = a
        u1, v1 = b
        steps = max(abs(u1 - u0), abs(v1 - v0))
        if steps == 0.0:  # a single point
            if not skip_first and (dash is None or phase % (dash[0] + dash[1]) < dash[0]):
                self.dot(math.floor(u0), math.floor(v0))
            return phase + (0 if skip_first else 1)
        clip = self._clip(u0, v0, u1, v1)
        if clip is None:
            return phase + round(steps)
        t0, t1 = clip
        n = max(1, math.ceil(steps * (t1 - t0)))
        phase += round(steps * t0)
        period = dash[0] + dash[1] if dash is not None else 0
        for k in range(1 if skip_first and t0 == 0.0 else 0, n + 1):
            t = t0 + (t1 - t0) * k / n
            if dash is None or phase % period < dash[0]:
                self.dot(int(u0 + (u1 - u0) * t), int(v0 + (v1 - v0) * t))
            phase += 1
        return phase + round(steps * (1.0 - t1))

    def line(self, x0: float, y0: float, x1: float, y1: float, dash: Dash | None = None) -> None:
        """A straight line between two world points (clipped to the canvas)."""
        self.polyline([(x0, y0), (x1, y1)], dash=dash)

    def polyline(self, points: Iterable[Point], *, closed: bool = False,
                 dash: Dash | None = None) -> None:
        """Connected world points; a non-finite point breaks the line.  The dash pattern runs on
        along the whole polyline."""
        phase = 0
        prev: Point | None = None
        first: Point | None = None
        x0, y1 = self.x_range[0], self.y_range[1]
        sx, sy = self._sx, self._sy
        for x, y in points:
            if not (math.isfinite(x) and math.isfinite(y)):
                prev = None
                continue
            p = ((x - x0) * sx, (y1 - y) * sy)
            if first is None:
                first = p
            if prev is None:
                phase = self._segment(p, p, dash, phase, False)
            elif dash is None and int(p[0]) == int(prev[0]) and int(p[1]) == int(prev[1]):
                pass  # same dot as the previous point (dense data): nothing new to draw
            else:
                phase = self._segment(prev, p, dash, phase, True)
            prev = p
        if closed and prev is not None and first is not None:
            self._segment(prev, first, dash, phase, True)

    def circle(self, cx: float, cy: float, r: float, dash: Dash | None = None) -> None:
        """A circle of radius ``r`` (world units) about (cx, cy)."""
        self.ellipse(cx, cy, r, r, 0.0, dash=dash)

    def ellipse(self, cx: float, cy: float, a: float, b: float, az_deg: float,
                dash: Dash | None = None) -> None:
        """An ellipse with semi-axes ``a`` (major) and ``b`` (minor) in world units, the major
        axis at azimuth ``az_deg`` (degrees clockwise from north = from +y towards +x)."""
        if not all(math.isfinite(v) for v in (cx, cy, a, b, az_deg)) or a < 0.0 or b < 0.0:
            return
        az = math.radians(az_deg)
        ue, un = math.sin(az), math.cos(az)  # major axis (east, north)
        we, wn = un, -ue  # minor axis = major turned +90° (clockwise)
        span = max(a, b) * max(self._sx, self._sy)
        n = min(720, max(16, int(2.0 * math.pi * span / 1.5)))
        pts = []
        for k in range(n):
            t = 2.0 * math.pi * k / n
            ca, sb = a * math.cos(t), b * math.sin(t)
            pts.append((cx + ca * ue + sb * we, cy + ca * un + sb * wn))
        self.polyline(pts, closed=True, dash=dash)

    # ------------------------------------------------------------------ text
    def text(self, col: int, row: int, s: str) -> None:
        """Write ``s`` from cell (col, row) rightwards (clipped); it replaces the braille."""
        if not 0 <= row < self.height:
            return
        for i, ch in enumerate(s):
            c = col + i
            if 0 <= c < self.width:
                self._text[(row, c)] = ch

    def marker(self, x: float, y: float, ch: str) -> bool:
        """Put the character ``ch`` in the cell of a world point; False if it is off the canvas."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return False
        col, row = self.to_cell(x, y)
        if 0 <= col < self.width and 0 <= row < self.height:
            self._text[(row, col)] = ch
            return True
        return False

    def label(self, x: float, y: float, s: str) -> bool:
        """Text next to a world point: one cell to its right, or to its left if it would not
        fit.  False if the point is off the canvas."""
        if not (math.isfinite(x) and math.isfinite(y)) or not self.contains(x, y):
            return False
        col, row = self.to_cell(x, y)
        start = col + 1 if col + 1 + len(s) <= self.width else col - len(s)
        self.text(max(0, start), row, s)
        return True

    def scale_bar(self, length: float, label: str) -> None:
        """A horizontal bar of ``length`` world units with end ticks at the bottom left
        (from the second dot column of the last cell row), its label after it or above it."""
        row = self.height - 1
        u0 = 2
        u1 = u0 + max(1, round(length * self._sx))
        v = 4 * row + 2
        for u in range(u0, min(u1, self.dot_width - 1) + 1):
            self.dot(u, v)
        for u in (u0, u1):
            for dv in range(4):
                self.dot(u, 4 * row + dv)
        col = u1 // 2 + 2
        if col + len(label) <= self.width:
            self.text(col, row, label)
        else:
            self.text(1, row - 1, label)

    def lines(self) -> list[str]:
        """The canvas as ``height`` strings of exactly ``width`` characters."""
        out = []
        for row in range(self.height):
            base = row * self.width
            chars = []
            for col in range(self.width):
                ch = self._text.get((row, col))
                chars.append(ch if ch is not None else braille_char(self._bits[base + col]))
            out.append("".join(chars))
        return out


# ---------------------------------------------------------------------- charts
@dataclass(frozen=True)
class Series:
    """One line of a chart: ``points`` (x, y) in world units, ascending x; a non-finite y is a
    gap, and so is an x step larger than ``max_gap``; ``dash`` the line pattern; with ``join``
    false the points are drawn as separate dots (a scatter)."""

    points: Sequence[Point]
    dash: Dash | None = None
    max_gap: float = math.inf
    join: bool = True


def draw_series(canvas: BrailleCanvas, series: Series) -> None:
    """Draw ``series`` on ``canvas``: runs of joined points as polylines, lone points as dots."""
    if not series.join:
        for x, y in series.points:
            canvas.point(x, y)
        return
    run: list[Point] = []
    prev_x = -math.inf
    for x, y in series.points:
        if not (math.isfinite(x) and math.isfinite(y)):
            _flush_run(canvas, run, series.dash)
            run = []
            continue
        if run and x - prev_x > series.max_gap:
            _flush_run(canvas, run, series.dash)
            run = []
        run.append((x, y))
        prev_x = x
    _flush_run(canvas, run, series.dash)


def _flush_run(canvas: BrailleCanvas, run: list[Point], dash: Dash | None) -> None:
    if len(run) == 1:
        canvas.point(*run[0])
    elif len(run) > 2 * canvas.dot_width:
        canvas.polyline(_envelope(canvas, run), dash=dash)
    elif run:
        canvas.polyline(run, dash=dash)


def _envelope(canvas: BrailleCanvas, run: list[Point]) -> list[Point]:
    """A dense run (ascending x) reduced to at most four points per dot column: the first,
    the extremes in the order they occur, and the last; it draws the same dots."""
    out: list[Point] = []
    col: list[Point] = []
    cur = None
    for p in run:
        u = int(canvas.to_dot(p[0], 0.0)[0])
        if u != cur and col:
            out.extend(_column_points(col))
            col = []
        cur = u
        col.append(p)
    if col:
        out.extend(_column_points(col))
    return out


def _column_points(col: list[Point]) -> list[Point]:
    if len(col) <= 4:
        return col
    lo = min(range(len(col)), key=lambda i: col[i][1])
    hi = max(range(len(col)), key=lambda i: col[i][1])
    inner = sorted({lo, hi} - {0, len(col) - 1})
    return [col[0], *(col[i] for i in inner), col[-1]]


def chart_lines(
    width: int,
    height: int,
    series: Sequence[Series],
    x_range: tuple[float, float],
    y_range: tuple[float, float],
    *,
    x_step: float | None = None,
    x_labels: bool = True,
    x_axis: bool = True,
    x_format: Callable[[float], str] = lambda v: f"{v:g}",
    y_format: Callable[[float], str] = lambda v: f"{v:g}",
    label_width: int = 7,
    zero_line: bool = False,
) -> list[str]:
    """A framed chart ``width`` × ``height`` characters: y tick labels (``label_width`` wide,
    right-aligned) and a ``┤``/``│`` axis on the left, the braille plot area, the ``└──┬──``
    x axis under it (unless not ``x_axis``) and (if ``x_labels`` too) the x tick labels in the
    last row.  Ticks are at nice steps (``x_step`` if given); ``zero_line`` adds a dotted line at
    y = 0."""
    x_labels = x_labels and x_axis
    plot_w = width - label_width - 1
    plot_h = height - (2 if x_labels else 1 if x_axis else 0)
    if plot_w < 2 or plot_h < 1:
        raise ValueError(f"chart too small: {width}×{height}")
    cv = BrailleCanvas(plot_w, plot_h, x_range, y_range)
    y0, y1 = cv.y_range
    x0, x1 = cv.x_range
    if zero_line and y0 < 0.0 < y1:
        cv.line(x0, 0.0, x1, 0.0, dash=(1, 3))
    for s in series:
        draw_series(cv, s)
    body = cv.lines()
    ylab: dict[int, str] = {}
    for t in ticks(y0, y1, nice_step(y1 - y0, max(1, plot_h // 2))):
        _, v = cv.to_dot(x0, t)
        row = min(plot_h - 1, max(0, math.floor(v / 4.0)))
        ylab.setdefault(row, y_format(t))
    out = []
    for row, text in enumerate(body):
        lab = ylab.get(row)
        axis = "┤" if lab is not None else "│"
        out.append((lab or "").rjust(label_width)[-label_width:] + axis + text)
    if not x_axis:
        return out
    xt = ticks(x0, x1, x_step if x_step is not None else nice_step(x1 - x0, max(1, plot_w // 8)))
    cols = [min(plot_w - 1, max(0, math.floor(cv.to_dot(t, y0)[0] / 2.0))) for t in xt]
    axis_row = ["─"] * plot_w
    for c in cols:
        axis_row[c] = "┬"
    out.append(" " * label_width + "└" + "".join(axis_row))
    if x_labels:
        row_chars = [" "] * width
        free_from = 0
        for t, c in zip(xt, cols, strict=True):
            s = x_format(t)
            start = label_width + 1 + c - len(s) // 2
            start = min(max(start, free_from), width - len(s))
            if start < free_from:
                continue
            row_chars[start:start + len(s)] = list(s)
            free_from = start + len(s) + 1
        out.append("".join(row_chars))
    return out
