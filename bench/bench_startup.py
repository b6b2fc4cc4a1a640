"""Start-up benchmarks (no assertions; prints medians over repeats, with the conditions).

1. ``uvnav replay data/920917_1.RUN --no-out`` in a fresh process: wall time from spawn to exit.
2. The console's first paint in a real terminal: ``uvnav`` in a detached tmux session of
   160×50 (a private tmux server, started once so its start is not counted), from the
   ``new-session`` call until the menu bar ("Quit  Edit  Setup") is on the tmux screen, read
   every :data:`POLL_S` seconds.

Each also gives the CPU time of the process (user + system): the machine is shared, and wall
time follows its load while CPU time hardly does.  Each is measured with a warm bytecode cache
(filled by one untimed run) and without one: an empty ``PYTHONPYCACHEPREFIX`` per run, so every
module (the project, NumPy, SciPy, Textual…) is compiled from source, as on the first start
after installing.  Timings belong here, never in a test: the machine is shared and the figures
vary with its load (printed with them).

Run: ``.venv/bin/python bench/bench_startup.py [--repeats N]`` (``make bench`` runs it).
"""

from __future__ import annotations

import argparse
import os
import resource
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from bench import child_env

ROOT = Path(__file__).resolve().parents[1]
REPLAY_ARGS = ("replay", "data/920917_1.RUN", "--no-out")
TERM_SIZE = (160, 50)
MENU_TEXT = "Quit  Edit  Setup"
"""The menu bar: on the screen once the console has painted its first frame."""
POLL_S = 0.01
"""How often the tmux screen is read while waiting (each figure is late by up to this)."""
TMUX_SOCKET = f"uvnav-startup-{os.getpid()}"


def _uvnav(python: Path | None = None) -> list[str]:
    """The command that starts uvnav with ``python`` (None: this interpreter)."""
    return [str(python or sys.executable), "-m", "uvnav_tui.cli.main"]


def replay_once(pycache: Path | None = None) -> tuple[float, float]:
    """Seconds of one ``uvnav replay data/920917_1.RUN --no-out`` in a fresh process: wall
    clock and CPU time (user + system) of the process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([*_uvnav(), *REPLAY_ARGS], cwd=ROOT, env=child_env(pycache), check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _process_cpu(pid: int) -> float:
    """CPU seconds (user + system) of process ``pid`` so far (Linux ``/proc``; NaN elsewhere)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as f:
            fields = f.read().rsplit(")", 1)[1].split()
    except OSError:
        return float("nan")
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _tmux(*args: str, check: bool = True) -> str:
    return subprocess.run(["tmux", "-L", TMUX_SOCKET, *args], check=check,
                          capture_output=True, text=True).stdout


def first_paint_once(pycache: Path | None = None, timeout_s: float = 60.0,
                     python: Path | None = None, cwd: Path = ROOT, pure: bool = False
                     ) -> tuple[float, float]:
    """Seconds from starting ``uvnav`` in a new tmux session until the menu bar is painted,
    wall clock and CPU time of the process by then (±10 ms; NaN if it did not appear within
    ``timeout_s``). ``python`` runs it (None: this interpreter) in ``cwd`` (the tree whose
    ``uvnav`` starts; bench_baseline.py times other trees), ``pure``: with ``UVNAV_PURE=1``."""
    cols, rows = TERM_SIZE
    session = f"paint{time.monotonic_ns()}"
    prefix = f"PYTHONPYCACHEPREFIX={pycache} " if pycache is not None else ""
    prefix += "UVNAV_PURE=1 " if pure else ""
    cmd = (f"cd {shlex.quote(str(cwd))} && exec env -u PYTHONDONTWRITEBYTECODE -u UVNAV_PURE "
           f"{prefix}{' '.join(shlex.quote(a) for a in _uvnav(python))}")
    t0 = time.perf_counter()
    _tmux("new-session", "-d", "-s", session, "-x", str(cols), "-y", str(rows), cmd)
    try:
        pid = int(_tmux("display", "-p", "-t", session, "#{pane_pid}", check=False) or 0)
        while time.perf_counter() - t0 < timeout_s:
            screen = _tmux("capture-pane", "-p", "-t", session, check=False)
            if MENU_TEXT in screen:
                return time.perf_counter() - t0, _process_cpu(pid)
            time.sleep(POLL_S)
        return float("nan"), float("nan")
    finally:
        _tmux("kill-session", "-t", session, check=False)


def _cold_and_warm(once: Callable[[Path | None], tuple[float, float]], repeats: int
                   ) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """``repeats`` runs without a bytecode cache, then ``repeats`` with a warm one."""
    cold = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory(prefix="uvnav-pycache-") as empty:
            cold.append(once(Path(empty)))
    with tempfile.TemporaryDirectory(prefix="uvnav-pycache-") as cache:
        once(Path(cache))  # fills the cache
        warm = [once(Path(cache)) for _ in range(repeats)]
    return cold, warm


def _line(what: str, runs: list[tuple[float, float]]) -> str:
    xs = [wall for wall, _cpu in runs]
    good = [x for x in xs if x == x]
    med = f"{statistics.median(good):.3f} s" if good else "n/a"
    cpus = [cpu for _wall, cpu in runs if cpu == cpu]
    cpu = f", CPU {statistics.median(cpus):.3f} s" if cpus else ""
    return f"{what}: median {med}{cpu} (runs: {', '.join(f'{x:.3f}' for x in xs)})"


def main() -> None:
    """Run the benchmarks and print the medians."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args, _rest = parser.parse_known_args()
    print(f"start-up, {os.cpu_count()} CPU(s), load average {os.getloadavg()[0]:.1f} at the "
          f"start, Python {sys.version.split()[0]}, medians of {args.repeats}")
    cold, warm = _cold_and_warm(replay_once, args.repeats)
    print(_line("uvnav replay data/920917_1.RUN --no-out, warm bytecode cache", warm))
    print(_line("uvnav replay data/920917_1.RUN --no-out, no bytecode cache", cold))
    if shutil.which("tmux") is None:
        print("tmux not found: the console's first paint is skipped")
        return
    cols, rows = TERM_SIZE
    _tmux("new-session", "-d", "-s", "keep", "sleep 3600")  # the server, started once
    try:
        cold, warm = _cold_and_warm(first_paint_once, args.repeats)
    finally:
        _tmux("kill-server", check=False)
    print(_line(f"console first paint in tmux {cols}×{rows}, warm bytecode cache", warm))
    print(_line(f"console first paint in tmux {cols}×{rows}, no bytecode cache", cold))


if __name__ == "__main__":
    main()
