"""The runs the tolerance contract is checked on, and the pure-Python reference logs of them.

Each case is a run: the thesis sample, a slice of the GPS + Decca demo, every bundled real NMEA
log (a slice of the longer ones) and a simulated slice of every ``data/scenarios`` mission (seed
1). :func:`replay_case` writes a case's ``.OUT``; ``python -m tests.out_reference DIR [NAME …]``
writes them all into DIR, which is how ``tests/run/test_out_unchanged.py`` makes the reference
logs in a process with ``UVNAV_PURE=1`` (no compiled kernel loaded) while it replays the same
cases with the kernels itself, then compares them field by field (:mod:`tests.tolerance`).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from engine.run.config import RunConfig, load_config
from engine.run.session import Session
from tests.paths import DATA

SCENARIOS = DATA / "scenarios"
MISSIONS = ("G1_GNSS_HDOP", "M1_SURF9B", "M2_DECCA2E", "M3_GPS_CM_MIDNIGHT", "M4_GPS_SW_WGS84",
            "M5_DIVE30", "M6_DIVE150")
"""The simulated missions of data/scenarios (each a .scenario.toml and a start-up .toml)."""


@dataclass(frozen=True)
class Case:
    """One run: its configuration (made in ``work``, a scratch folder) and how many cycles of
    it are replayed (None: all)."""

    config: Callable[[Path], RunConfig]
    max_cycles: int | None


def _config_file(path: Path) -> Callable[[Path], RunConfig]:
    return lambda _work: load_config(path)


def _mission(name: str, records: int) -> Callable[[Path], RunConfig]:
    """Mission ``name`` simulated (seed 1), its first ``records`` records written to a .RUN in
    ``work``, the start-up configuration pointed at it."""

    def make(work: Path) -> RunConfig:
        from engine.run.setup import read_data_dir
        from engine.sim.scenario import load_scenario
        from engine.sim.simulate import simulate

        scenario = load_scenario(SCENARIOS / f"{name}.scenario.toml")
        lines = []
        for _truth, rec in simulate(scenario, *read_data_dir(DATA), 1):
            lines.append(rec.raw + "\n")
            if len(lines) >= records:
                break
        run = work / f"{name}.RUN"
        run.write_text("".join(lines), encoding="ascii")
        return load_config(SCENARIOS / f"{name}.toml").replace(run_file=str(run))

    return make


def _standin(path: Path) -> Callable[[Path], RunConfig]:
    """The log of ``path`` with COG/SOG standing in for the missing gyro and log: the learnt
    motion noise (engine.filter.motion) and its MOTION lines."""

    def make(_work: Path) -> RunConfig:
        from dataclasses import replace

        cfg = load_config(path)
        return cfg.replace(sensors=replace(cfg.sensors, cog_sog="standin"))

    return make


CASES: dict[str, Case] = {
    "SAMPLE": Case(_config_file(DATA / "920917_1.toml"), None),
    "DEMO": Case(_config_file(DATA / "DEMO.toml"), 1500),
    **{f"NMEA_{p.stem}": Case(_config_file(p), 3000)
       for p in sorted((DATA / "nmea").glob("*.toml"))},
    "NMEA_baltic_standin": Case(_standin(DATA / "nmea" / "avnav-baltic-20130731.toml"), 3000),
    **{f"SIM_{m}": Case(_mission(m, 400), None) for m in MISSIONS},
}
"""Case name → run. Slices keep the pure-Python reference run within a few minutes."""


def replay_case(name: str, out: Path) -> Path:
    """Replay case ``name`` into the log ``out`` (scratch files beside it); returns ``out``."""
    case = CASES[name]
    work = out.parent / f"{name}.work"
    work.mkdir(parents=True, exist_ok=True)
    session = Session(case.config(work), out_path=out, force=True, history=1)
    try:
        session.run(max_cycles=case.max_cycles)
    finally:
        session.close()
    return out


def main(argv: list[str]) -> int:
    """``DIR [NAME …]``: write every case's (or the named cases') ``.OUT`` into DIR."""
    folder = Path(argv[0])
    for name in argv[1:] or sorted(CASES):
        replay_case(name, folder / f"{name}.OUT")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
