"""Tuning/validation split of the GPS-denied experiment on a bundled real log (docs/REALDATA.md,
"Tuning the surface vessel").

    .venv/bin/python -m tests.denied_halves LOG_NAME '{"key": value}' '[600, 1800]' \
        EVERY_S [standin]

runs ``engine.assess.denied.denied_experiment`` on ``data/nmea/LOG_NAME.nmea`` with its
configuration, the ``[filter]`` table ``FilterConfig.from_vessel(vessel, **keys)`` (``vessel``
from the JSON, default "surface"; ``"log": "off"`` switches the water-speed log off) and, with
``standin``, ``sensors.cog_sog = "standin"``. It prints one JSON line: per half of the windows
in time order ("A" = first half, the tuning set; "B" = second half; "all") and checkpoint
(minutes): windows, median and 90th-percentile filter error [m], % of windows whose hidden fix
was inside the 95 % ellipse, median ellipse semi-major axis [m], median semi-major axis / error,
median error of the straight COG/SOG line [m].
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from typing import Any

import numpy as np

from engine.assess.denied import denied_experiment, run_records
from engine.run.config import FilterConfig
from engine.run.session import load_run_config
from tests.paths import DATA


def run(name: str, overrides: dict[str, Any], lengths: list[float], every_s: float,
        standin: bool = False,
        checkpoints_s: tuple[float, ...] = (60.0, 300.0, 600.0, 1800.0)) -> dict[str, Any]:
    """The statistics described in the module docstring, as a dict."""
    cfg, data = load_run_config(DATA / "nmea" / f"{name}.toml")
    keys = dict(overrides)
    vessel = keys.pop("vessel", "surface")
    log_state = keys.pop("log", None)
    sensors = cfg.sensors
    if standin:
        sensors = dataclasses.replace(sensors, cog_sog="standin")
    if log_state:
        sensors = dataclasses.replace(sensors, log=log_state)
    cfg = cfg.replace(filter=FilterConfig.from_vessel(vessel, **keys), sensors=sensors)
    t0 = time.time()
    rep = denied_experiment(cfg, data, run_records(cfg), lengths, every_s=every_s,
                            warmup_s=120.0, checkpoints_s=checkpoints_s)
    wins = rep.windows
    half = len(wins) // 2
    out: dict[str, Any] = {"n": len(wins), "secs": round(time.time() - t0)}
    for label, sel in (("A", wins[:half]), ("B", wins[half:]), ("all", wins)):
        for cp in checkpoints_s:
            pts = [p for w in sel for p in w.points if p.checkpoint_s == cp]
            if not pts:
                continue
            err = np.array([p.filter_error_m for p in pts])
            a95 = np.array([p.filter_a95_m for p in pts])
            inside = float(np.mean([p.filter_inside95 for p in pts]))
            cog = np.array([p.cogsog_error_m for p in pts])
            out[f"{label}{int(cp / 60)}"] = (
                len(pts), round(float(np.median(err))), round(float(np.percentile(err, 90))),
                round(100 * inside), round(float(np.median(a95))),
                round(float(np.median(a95 / np.maximum(err, 1e-3))), 1),
                round(float(np.median(cog))))
    return out


if __name__ == "__main__":
    args = sys.argv[1:]
    result = run(args[0], json.loads(args[1]), json.loads(args[2]), float(args[3]),
                 standin=len(args) > 4 and args[4] == "standin")
    print(args[1], json.dumps(result), flush=True)
