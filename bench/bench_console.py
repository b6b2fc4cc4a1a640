"""Console benchmarks (no assertions; prints medians over repeats).

1. Start-up: wall time from process start (``uvnav`` in a pseudo-terminal, 100×30) to the first
   painted frame: the state line (``Pg 100``) and the start-up dialog arriving on the terminal.
2. Sustained cycles/s at pace "as fast as possible" on the 2 h demo (7200 records) with the main
   page visible and refreshed (headless console, 100×30), compared with the bare engine.

Run: ``.venv/bin/python bench/bench_console.py [--repeats N]``.
"""

from __future__ import annotations

import argparse
import asyncio
import fcntl
import os
import pty
import select
import shutil
import signal
import statistics
import struct
import subprocess
import sys
import tempfile
import termios
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DATA_FILES = ("TO_WGS84.DAT", "DECCA.CHN", "DEMO.RUN", "DEMO.toml")


def private_data() -> Path:
    """A temporary copy of the demo data (the console writes its .OUT next to the .RUN)."""
    target = Path(tempfile.mkdtemp(prefix="uvnav-bench-"))
    for name in DATA_FILES:
        shutil.copy(ROOT / "data" / name, target / name)
    return target


def startup_once(config: Path, timeout_s: float = 20.0) -> float:
    """Seconds from spawning ``uvnav`` in a pty until the menu bar is painted."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    env = dict(os.environ, TERM="xterm-256color", COLUMNS="100", LINES="30")
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "uvnav_tui.cli", "--config", str(config),
         "--hardcopy-dir", str(config.parent / "hardcopy")],
        stdin=slave, stdout=slave, stderr=slave, cwd=ROOT, env=env, start_new_session=True)
    os.close(slave)
    seen = b""
    elapsed = float("nan")
    try:
        while time.perf_counter() - t0 < timeout_s:
            ready, _, _ = select.select([master], [], [], 0.05)
            if not ready:
                continue
            try:
                chunk = os.read(master, 65536)
            except OSError:
                break
            seen += chunk
            if b"Pg 100" in seen and b"Geodetic datum" in seen:
                elapsed = time.perf_counter() - t0
                break
    finally:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        os.close(master)
    return elapsed


def engine_rate(config: Path) -> float:
    """Cycles/s of the bare engine over the whole demo (with smoother collection, as the
    console runs it)."""
    from engine.session import Session

    session = Session.from_file(config, collect_smoother=True)
    t0 = time.perf_counter()
    n = 0
    while session.step() is not None:
        n += 1
    return n / (time.perf_counter() - t0)


async def _console_rate(config: Path) -> tuple[float, int]:
    from engine.runconfig import load_config
    from uvnav_tui.app import UVNAVApp

    # The demo asks "Discard LOP?" 6 times (LOPReject = A, the thesis default); the app answers
    # "no" itself, as `uvnav script` answers with `lop`, so an unanswered question cannot stall
    # the run (it did: make bench hung at the first one).
    app = UVNAVApp(load_config(config), pace_override="fast", write_logs=False,
                   hardcopy_dir=config.parent / "hardcopy", lop_policy="no")
    async with app.run_test(size=(100, 30)) as pilot:
        await pilot.pause()
        await pilot.press("enter")
        t0 = time.perf_counter()
        assert app.control is not None
        while not app.control.eof:
            await asyncio.sleep(0.01)
        elapsed = time.perf_counter() - t0
        return app.control.cycles / elapsed, app.control.cycles


def console_rate(config: Path) -> float:
    """Cycles/s of the console at "fast" with the main page visible."""
    rate, _n = asyncio.run(_console_rate(config))
    return rate


def main() -> None:
    """Run the benchmarks and print the medians."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    data = private_data()
    config = data / "DEMO.toml"
    startups = [startup_once(config) for _ in range(args.repeats)]
    print(f"start-up to first painted frame: median {statistics.median(startups):.2f} s "
          f"(runs: {', '.join(f'{s:.2f}' for s in startups)})")
    engine = [engine_rate(config) for _ in range(args.repeats)]
    print(f"bare engine, demo 7200 records: median {statistics.median(engine):.0f} cycles/s")
    console = [console_rate(config) for _ in range(args.repeats)]
    print(f"console at pace fast, Pg 100 visible: median {statistics.median(console):.0f} "
          f"cycles/s (runs: {', '.join(f'{c:.0f}' for c in console)})")
    shutil.rmtree(data, ignore_errors=True)


if __name__ == "__main__":
    main()
