"""The tolerance contract between the compiled kernels and the pure-Python reference.

The pure-Python engine is the reference; the compiled path must agree with it (docs/
PERFORMANCE.md, "Compiled kernels"): every logged number within 1e-9 relative, or an absolute
floor (1e-6 m, 1e-9°, 1e-9 of a lane) where that is larger, and every discrete field identical
(flags, verdicts, rejected LOPs, lanes, counts, message texts, the ``.OUT`` line structure).

:func:`close` applies it to values a kernel returns (floats, arrays, tuples, dataclasses);
:func:`compare_out` to two ``.OUT`` logs, field by field; :func:`compare_jsonl` to two JSON-lines
files. Each returns a list of differences (empty: they agree), so a failing test names the line,
the key and both values.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

RTOL = 1e-9
"""Relative tolerance of every number."""
ATOL_DEFAULT = 1e-9
"""Absolute floor for a number whose unit the key does not say (degrees, lanes, ratios)."""
ATOL_METRES = 1e-6
"""Absolute floor for lengths in metres (positions, ellipse axes, residuals)."""

METRE_KEYS = frozenset({"x", "y", "z", "depth", "a95", "b95", "rms", "sd", "s_x", "s_y",
                        "s_z", "drms", "dist", "range"})
"""Keys of the ``.OUT`` whose values are lengths in metres (grid x/y, depth, ellipse axes,
RMS and standard deviations of position)."""


STATISTIC_KEYS = frozenset({"lom", "w", "s2", "tau", "ls", "t", "T", "nis"})
"""Keys of test statistics: quadratic forms and ratios of innovations and residuals in units
of their σ. An innovation is a difference of two grid coordinates (~10⁶ m): one unit in the
last place of a coordinate (~1e-9 m) moves it, and its statistic, by far more than 1e-9
relative, so a statistic gets the floor of a length, ``ATOL_METRES`` (1e-6 σ)."""


def atol_for(key: str) -> float:
    """The absolute floor of a logged field ``key``: 1e-6 for lengths in metres (and keys
    ending in ``_m``) and for test statistics (in σ), else 1e-9 (degrees, lanes, ratios)."""
    if key in METRE_KEYS or key in STATISTIC_KEYS or key.endswith("_m"):
        return ATOL_METRES
    return ATOL_DEFAULT


def ellipse_az_tolerance(fields: dict[str, str]) -> float | None:
    """The tolerance (degrees) of the axis azimuth ``az`` of an error ellipse logged with its
    VCV (``cxx``, ``cxy``, ``cyy``, m²) on the same line: the rotation the contract's own
    tolerance on the VCV (1e-9 of its largest entry) can cause, 1e-9·c / (λ₁ − λ₂) rad (a
    first-order perturbation of the eigenvectors; a near-circular ellipse has an ill-defined
    axis), at least 1e-9°; None when the line has no VCV."""
    try:
        cxx, cxy, cyy = (float(fields[k]) for k in ("cxx", "cxy", "cyy"))
    except (KeyError, ValueError):
        return None
    gap = math.hypot(cxx - cyy, 2.0 * cxy)
    c = max(abs(cxx), abs(cyy), abs(cxy))
    if not math.isfinite(gap) or not math.isfinite(c):
        return None
    if gap <= 0.0:
        return 180.0
    return max(ATOL_DEFAULT, math.degrees(RTOL * c / gap))


def covariance_tolerance(fields: dict[str, str]) -> float | None:
    """The absolute tolerance (m²) of a VCV's off-diagonal ``cxy`` logged with its diagonal:
    1e-9·√(cxx·cyy), the contract's relative tolerance of the scale Cauchy–Schwarz bounds it
    by (|cxy| ≤ √(cxx·cyy)); a covariance that nearly cancels is a small difference of large
    products, so it is judged against that scale, not against itself. None without the
    diagonal."""
    try:
        cxx, cyy = float(fields["cxx"]), float(fields["cyy"])
    except (KeyError, ValueError):
        return None
    if not (math.isfinite(cxx) and math.isfinite(cyy)) or cxx < 0.0 or cyy < 0.0:
        return None
    return max(ATOL_DEFAULT, RTOL * math.sqrt(cxx * cyy))


def numbers_close(a: float, b: float, atol: float = ATOL_DEFAULT, scale: float = 0.0,
                  rtol: float = RTOL) -> bool:
    """``a`` and ``b`` within ``RTOL`` of the larger of them (or of ``scale``, an array's
    largest entry: a covariance's cancelling off-diagonal is judged against its diagonal), or
    within ``atol``; NaN only against NaN, infinities only against themselves."""
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= max(atol, rtol * max(abs(a), abs(b), scale))


def close(got: Any, want: Any, atol: float = ATOL_DEFAULT, path: str = "",
          rtol: float = RTOL) -> list[str]:
    """Differences between ``got`` (compiled) and ``want`` (reference) beyond the contract:
    numbers (floats, float arrays) within tolerance, everything else (types, shapes, dtypes,
    ints, bools, strings, None) identical; containers and dataclasses element by
    element."""
    where = path or "value"
    if isinstance(want, np.ndarray) or isinstance(got, np.ndarray):
        if not (isinstance(want, np.ndarray) and isinstance(got, np.ndarray)):
            return [f"{where}: {type(got).__name__} vs {type(want).__name__}"]
        if got.shape != want.shape or got.dtype != want.dtype:
            return [f"{where}: shape/dtype {got.shape} {got.dtype} vs {want.shape} {want.dtype}"]
        if want.dtype.kind != "f":
            return [] if np.array_equal(got, want) else [f"{where}: {got} vs {want}"]
        finite = want[np.isfinite(want)]
        scale = float(np.abs(finite).max()) if finite.size else 0.0
        bad = [i for i, (g, w) in enumerate(zip(got.ravel().tolist(), want.ravel().tolist(),
                                                 strict=True))
               if not numbers_close(g, w, atol, scale, rtol)]
        return [f"{where}[{i}]: {got.ravel()[i]!r} vs {want.ravel()[i]!r}" for i in bad[:5]]
    if isinstance(want, bool) or isinstance(got, bool) or want is None or got is None:
        return [] if got is want or (type(got) is type(want) and got == want) else [
            f"{where}: {got!r} vs {want!r}"]
    if isinstance(want, float) and isinstance(got, float | int):
        if numbers_close(float(got), want, atol, 0.0, rtol):
            return []
        return [f"{where}: {got!r} vs {want!r}"]
    if type(got) is not type(want):
        return [f"{where}: type {type(got).__name__} vs {type(want).__name__}"]
    if isinstance(want, int | str | bytes):
        return [] if got == want else [f"{where}: {got!r} vs {want!r}"]
    if isinstance(want, tuple | list):
        if len(got) != len(want):
            return [f"{where}: length {len(got)} vs {len(want)}"]
        out: list[str] = []
        for i, (g, w) in enumerate(zip(got, want, strict=True)):
            out += close(g, w, atol, f"{where}[{i}]", rtol)
        return out
    if isinstance(want, dict):
        if got.keys() != want.keys():
            return [f"{where}: keys {sorted(got)} vs {sorted(want)}"]
        out = []
        for k in want:
            out += close(got[k], want[k], atol, f"{where}.{k}", rtol)
        return out
    if dataclasses.is_dataclass(want):
        out = []
        for f in dataclasses.fields(want):
            out += close(getattr(got, f.name), getattr(want, f.name), atol, f"{where}.{f.name}",
                         rtol)
        return out
    return [] if got == want else [f"{where}: {got!r} vs {want!r}"]


class Near:
    """A value that equals another to the tolerance contract (:func:`close`; ``atol``: one
    floor, or one per element of a tuple, e.g. (1e-9, 1e-9, 1e-6) for lat°, lon°, h m), so the
    tests written as ``a == b`` compare to the contract."""

    def __init__(self, v: Any, atol: float | tuple[float, ...] = ATOL_DEFAULT,
                 rtol: float = RTOL) -> None:
        self.v = v
        self.atol = atol
        self.rtol = rtol

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Near):
            return NotImplemented
        if isinstance(self.atol, tuple):
            if not (isinstance(self.v, tuple | list) and isinstance(other.v, tuple | list)
                    and len(self.v) == len(other.v) == len(self.atol)):
                return False
            return all(not close(a, b, t, rtol=max(self.rtol, other.rtol))
                       for a, b, t in zip(self.v, other.v, self.atol, strict=True))
        return not close(self.v, other.v, self.atol, rtol=max(self.rtol, other.rtol))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"Near({self.v!r})"


def assert_close(got: Any, want: Any, atol: float = ATOL_DEFAULT) -> None:
    """Fail with the first differences when ``got`` and ``want`` break the contract."""
    diffs = close(got, want, atol)
    assert not diffs, "compiled and pure differ beyond the tolerance contract:\n" + "\n".join(
        diffs[:10])


# ------------------------------------------------------------------------------- .OUT logs

_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^[-+]?(inf|nan)$")


def _token_number(text: str) -> float | None:
    """The value of a logged number, or None when the text is no number (compared as text)."""
    return float(text) if _NUMBER.match(text) else None


def _values_agree(got: str, want: str, key: str, atol: float | None = None) -> bool:
    """One logged value: equal texts, or two numbers (or comma lists of numbers, element by
    element) within the contract (``atol``: the key's floor, :func:`atol_for`, by default)."""
    if got == want:
        return True
    floor = atol_for(key) if atol is None else atol
    pg, pw = got.split(","), want.split(",")
    if len(pg) != len(pw):
        return False
    for a, b in zip(pg, pw, strict=True):
        if a == b:
            continue
        g, w = _token_number(a), _token_number(b)
        if g is None or w is None or not numbers_close(g, w, floor):
            return False
    return True


def split_fields(line: str) -> list[str]:
    """Tokens of an ``.OUT`` line: blank-separated, with JSON-quoted values kept whole."""
    out, i, n = [], 0, len(line)
    while i < n:
        if line[i] == " ":
            i += 1
            continue
        j = i
        while j < n and line[j] != " ":
            if line[j] == '"':
                j += 1
                while j < n and line[j] != '"':
                    j += 2 if line[j] == "\\" else 1
            j += 1
        out.append(line[i:j])
        i = j
    return out


def compare_lines(got: list[str], want: list[str], name: str = "log") -> list[str]:
    """Differences between two logs' lines (compiled, reference): the same number of lines,
    each with the same fields in the same order; ``key=value`` values compared by
    :func:`_values_agree` (an ellipse's ``az`` by :func:`ellipse_az_tolerance`; a LOP's
    residual ``v`` and ``sd`` in lanes for Decca, in metres for other systems), every other
    token (record words, keys, texts) identical."""
    diffs: list[str] = []
    if len(got) != len(want):
        diffs.append(f"{name}: {len(got)} lines, the reference has {len(want)}")
    for no, (g, w) in enumerate(zip(got, want, strict=False), 1):
        if g == w:
            continue
        tg, tw = split_fields(g), split_fields(w)
        if len(tg) != len(tw):
            diffs.append(f"{name}:{no}: {len(tg)} fields vs {len(tw)}:\n  {g}\n  {w}")
            continue
        fields = dict(t.split("=", 1) for t in tw if "=" in t)
        metres_lop = tw[0] == "LOP" and fields.get("sys") not in (None, "Decca")
        for a, b in zip(tg, tw, strict=True):
            ka, _, va = a.partition("=")
            kb, _, vb = b.partition("=")
            if a == b:
                continue
            atol = ellipse_az_tolerance(fields) if ka == "az" else None
            if ka == "cxy":
                atol = covariance_tolerance(fields)
            if metres_lop and ka in ("v", "sd"):  # a GPS (or other metric) LOP: metres
                atol = ATOL_METRES
            if ka != kb or "=" not in a or "=" not in b or not _values_agree(va, vb, ka, atol):
                diffs.append(f"{name}:{no}: {a!r} vs {b!r}")
        if len(diffs) > 20:
            break
    return diffs


def compare_out(got: Path, want: Path, same_paths: tuple[str, str] | None = None) -> list[str]:
    """Differences between two ``.OUT`` logs (compiled ``got``, reference ``want``) beyond the
    contract. ``same_paths``: (folder in got, folder in want) that name the same place (two
    runs' scratch folders): replaced in got's text before comparing."""
    tg = got.read_text(encoding="utf-8")
    tw = want.read_text(encoding="utf-8")
    if same_paths is not None:
        tg = tg.replace(same_paths[0], same_paths[1])
    return compare_lines(tg.splitlines(), tw.splitlines(), got.name)


def compare_jsonl(got: Path, want: Path) -> list[str]:
    """Differences between two JSON-lines files, object by object, key by key."""
    lg = got.read_text(encoding="utf-8").splitlines()
    lw = want.read_text(encoding="utf-8").splitlines()
    diffs = [] if len(lg) == len(lw) else [f"{got.name}: {len(lg)} lines vs {len(lw)}"]
    for no, (a, b) in enumerate(zip(lg, lw, strict=False), 1):
        if a != b:
            diffs += [f"{got.name}:{no}: {d}" for d in close(json.loads(a), json.loads(b),
                                                               ATOL_METRES)]
    return diffs
