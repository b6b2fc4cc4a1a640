"""The export documents: GPX 1.1, GeoJSON (RFC 7946), CSV and KML 2.2 text from an
:class:`~engine.io.export_geo.ExportData` (pure functions: data in, text out; docs/EXPORT.md).

Every coordinate is WGS84 (latitude, longitude in degrees; GeoJSON and KML in lon, lat order);
elevation/altitude is −depth in metres relative to the sea surface (positive up). Times are UTC.

* **GPX** (:mod:`gpxpy`): one ``trk`` per track; a cycle without the estimate ends a segment;
  ``trkpt`` with ``time`` and, for the MPP and smoothed tracks, ``ele`` = −depth.
* **GeoJSON**: one ``LineString`` Feature per track (``"kind": "track"``), then per cycle and
  track one Feature (``"kind": "epoch"``) whose geometry is the 95 % error ellipse as a
  ``Polygon`` (closed, counter-clockwise) — or a ``Point`` when the estimate has no ellipse —
  with the cycle's properties. One Feature per line.
* **CSV**: a header row, then one row per cycle; time ISO 8601 UTC; numbers only in numeric
  columns (units in the column names), empty where there is no value.
* **KML**: ``xml.etree``; one ``Placemark`` with a ``LineString`` (lon,lat,alt) per track,
  ``altitudeMode`` ``clampToGround`` (the altitude −depth is kept, viewers draw on the surface).
"""

from __future__ import annotations

import csv
import io
import json
import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from typing import Any

from engine.io.export_geo import TRACK_TITLES, ExportData, GeoPoint
from engine.io.export_read import ExportEpoch

__all__ = [
    "CSV_EPOCH_COLUMNS",
    "CSV_TRACK_COLUMNS",
    "GENERATOR",
    "KML_NS",
    "csv_text",
    "geojson_text",
    "gpx_text",
    "kml_text",
]

GENERATOR = "UVNAV export"
"""Creator/generator mark of every export (also how ``--force`` recognises an earlier one)."""
KML_NS = "http://www.opengis.net/kml/2.2"
CSV_EPOCH_COLUMNS = ("time_utc", "cycle", "record", "source", "filter", "datum", "s2", "rms_m",
                     "lops_used", "w_max", "lops_flagged", "fix_failed", "messages")
"""The per-cycle CSV columns, first in every row."""
CSV_TRACK_COLUMNS = ("lat_deg", "lon_deg", "depth_m", "east_m", "north_m", "cm_deg", "a95_m",
                     "b95_m", "az_grid_deg", "az_true_deg")
"""The columns of each track, prefixed ``TRACK_`` (``mpp_lat_deg`` …): WGS84 degrees; grid
metres on the working datum and that grid's CM (degrees); 95 % semi-axes (m) and azimuths."""
_KML_COLOURS = {"mpp": "ff0000ff", "lse": "ff00a5ff", "gps": "ff00ff00", "smoothed": "ffff00ff"}
"""Line colours (KML aabbggrr): MPP red, LSE orange, GPS green, smoothed magenta."""


def _r(x: float | None, nd: int) -> float | None:
    return None if x is None or not math.isfinite(x) else round(x, nd)


def _time(e: ExportEpoch) -> str:
    return e.time.strftime("%Y-%m-%dT%H:%M:%S") + (
        f".{e.time.microsecond // 1000:03d}Z" if e.time.microsecond else "Z")


def _present(data: ExportData, name: str) -> Iterator[tuple[ExportEpoch, GeoPoint]]:
    for e, p in zip(data.epochs, data.tracks[name], strict=True):
        if p is not None:
            yield e, p


def gpx_text(data: ExportData) -> str:
    """GPX 1.1 document: one track per selected track (module docstring)."""
    import gpxpy.gpx  # imported on use (start-up time of the other commands)

    g = gpxpy.gpx.GPX()
    g.creator = GENERATOR
    g.name = f"UVNAV {data.source}"
    g.description = ("Positions on WGS84 (converted from " + ", ".join(data.datums)
                     + "); elevation = -depth (m, sea surface)")
    for name, pts in data.tracks.items():
        trk = gpxpy.gpx.GPXTrack(name=TRACK_TITLES[name])
        seg = None
        for e, p in zip(data.epochs, pts, strict=True):
            if p is None:
                seg = None
                continue
            if seg is None:
                seg = gpxpy.gpx.GPXTrackSegment()
                trk.segments.append(seg)
            seg.points.append(gpxpy.gpx.GPXTrackPoint(
                latitude=round(p.lat_deg, 9), longitude=round(p.lon_deg, 9),
                elevation=_r(p.elevation_m, 3), time=e.time))
        g.tracks.append(trk)
    return g.to_xml(version="1.1")


def _epoch_properties(e: ExportEpoch, name: str, p: GeoPoint) -> dict[str, Any]:
    return {
        "kind": "epoch", "track": name, "cycle": e.n, "time": _time(e), "record": e.record,
        "source": e.source, "filter": e.filter, "datum": e.datum,
        "lat_deg": _r(p.lat_deg, 9), "lon_deg": _r(p.lon_deg, 9), "depth_m": _r(p.depth_m, 3),
        "east_m": _r(p.east_m, 3), "north_m": _r(p.north_m, 3), "cm_deg": p.cm_deg,
        "a95_m": _r(p.a95_m, 3), "b95_m": _r(p.b95_m, 3),
        "az_grid_deg": _r(p.az_grid_deg, 3), "az_true_deg": _r(p.az_true_deg, 3),
        "s2": _r(e.s2, 6), "rms_m": _r(e.rms_m, 3), "lops_used": e.lops_used,
        "w_max": _r(e.w_max, 3), "lops_flagged": e.lops_flagged, "fix_failed": e.fix_failed,
        "messages": e.messages,
    }


def _lonlat(p: GeoPoint) -> list[float]:
    return [round(p.lon_deg, 9), round(p.lat_deg, 9)]


def geojson_text(data: ExportData, ellipses: bool = True) -> str:
    """GeoJSON FeatureCollection (RFC 7946; module docstring). ``ellipses`` False: a Point per
    cycle instead of the ellipse Polygon."""
    header = {"type": "FeatureCollection",
              "uvnav_export": {"generator": GENERATOR, "source": data.source, "crs": "WGS84",
                               "converted_from": list(data.datums),
                               "tracks": list(data.tracks),
                               "ellipse": "95 % error ellipse, counter-clockwise ring"}}
    features: list[str] = []
    dump = json.dumps
    for name in data.tracks:
        coords = [_lonlat(p) for _e, p in _present(data, name)]
        if len(coords) >= 2:
            times = [_time(e) for e, _p in _present(data, name)]
            features.append(dump({
                "type": "Feature",
                "geometry": {"type": "LineString", "coordinates": coords},
                "properties": {"kind": "track", "track": name, "title": TRACK_TITLES[name],
                               "points": len(coords), "start": times[0], "end": times[-1]},
            }, separators=(",", ":")))
    for i, e in enumerate(data.epochs):
        for name, pts in data.tracks.items():
            p = pts[i]
            if p is None:
                continue
            if ellipses and p.ring is not None:
                geom: dict[str, Any] = {"type": "Polygon", "coordinates": [
                    [[round(lo, 9), round(la, 9)] for lo, la in p.ring]]}
            else:
                geom = {"type": "Point", "coordinates": _lonlat(p)}
            features.append(dump({"type": "Feature", "geometry": geom,
                                  "properties": _epoch_properties(e, name, p)},
                                 separators=(",", ":"), allow_nan=False))
    head = dump(header, separators=(",", ":"))[:-1]
    return head + ',"features":[\n' + ",\n".join(features) + "\n]}\n"


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, float):
        return "" if not math.isfinite(v) else repr(v)
    return str(v)


def csv_text(data: ExportData) -> str:
    """CSV: a header row (:data:`CSV_EPOCH_COLUMNS`, then ``TRACK_`` + :data:`CSV_TRACK_COLUMNS`
    per track) and one row per cycle."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([*CSV_EPOCH_COLUMNS,
                *(f"{t}_{c}" for t in data.tracks for c in CSV_TRACK_COLUMNS)])
    for i, e in enumerate(data.epochs):
        row: list[Any] = [_time(e), e.n, e.record, e.source, e.filter, e.datum, e.s2, e.rms_m,
                          e.lops_used, e.w_max, e.lops_flagged, e.fix_failed, e.messages]
        for pts in data.tracks.values():
            p = pts[i]
            if p is None:
                row += [None] * len(CSV_TRACK_COLUMNS)
            else:
                row += [_r(p.lat_deg, 9), _r(p.lon_deg, 9), _r(p.depth_m, 3),
                        _r(p.east_m, 3), _r(p.north_m, 3), p.cm_deg, _r(p.a95_m, 3),
                        _r(p.b95_m, 3), _r(p.az_grid_deg, 3), _r(p.az_true_deg, 3)]
        w.writerow([_cell(v) for v in row])
    return buf.getvalue()


def kml_text(data: ExportData) -> str:
    """KML 2.2 document: one Placemark with a LineString (lon,lat,alt) per track that has at
    least two points (module docstring)."""
    ET.register_namespace("", KML_NS)

    def sub(parent: ET.Element, tag: str, text: str | None = None) -> ET.Element:
        el = ET.SubElement(parent, f"{{{KML_NS}}}{tag}")
        if text is not None:
            el.text = text
        return el

    root = ET.Element(f"{{{KML_NS}}}kml")
    doc = sub(root, "Document")
    sub(doc, "name", f"{GENERATOR} {data.source}")
    sub(doc, "description", "WGS84 (converted from " + ", ".join(data.datums)
        + "); altitude = -depth (m, sea surface)")
    for name in data.tracks:
        style = sub(doc, "Style")
        style.set("id", name)
        line = sub(style, "LineStyle")
        sub(line, "color", _KML_COLOURS.get(name, "ffffffff"))
        sub(line, "width", "2")
    for name in data.tracks:
        pts = [p for _e, p in _present(data, name)]
        if len(pts) < 2:
            continue
        times = [_time(e) for e, _p in _present(data, name)]
        pm = sub(doc, "Placemark")
        sub(pm, "name", TRACK_TITLES[name])
        sub(pm, "description", f"{len(pts)} points, {times[0]} to {times[-1]}")
        sub(pm, "styleUrl", f"#{name}")
        ls = sub(pm, "LineString")
        sub(ls, "tessellate", "1")
        sub(ls, "altitudeMode", "clampToGround")
        sub(ls, "coordinates", " ".join(
            f"{p.lon_deg:.9f},{p.lat_deg:.9f},{0.0 if p.elevation_m is None else p.elevation_m:.3f}"
            for p in pts))
    ET.indent(root)
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            + ET.tostring(root, encoding="unicode") + "\n")
