"""Console benchmarks (no assertions; prints medians over repeats, with the conditions).

1. Start-up: wall time from process start (``uvnav`` in a pseudo-terminal, 160×50) to the first
   painted frame: the state line (``Pg 100``) and the start-up dialog arriving on the terminal,
   in a fresh process without a bytecode cache (an empty ``PYTHONPYCACHEPREFIX``: every module
   compiled, as on the first start after installing) and with a warm one.
2. Sustained cycles/s at pace "as fast as possible" on the 2 h demo (7200 records) in a real
   terminal: ``uvnav`` inside a detached tmux session of 160×50 (tmux parses and keeps every
   frame, as a terminal does), on Pg 100 and on Pg 642 (the position plot), from Return in the
   start-up dialog to "End of data file" on the screen.  LOPReject is set to N in the private
   copy of the configuration so that no question stops the run.
   Also per CPU-second of the console process (all its threads, from ``/proc``) and the UI
   thread's share of it: on a shared machine the wall-clock rate follows the load, these don't.
3. The bare engine, without and with the ``.OUT`` written (the console writes it, so the
   ratio console / engine alone is taken against the latter, in CPU time), and the same run
   headless (Textual's test driver, 100×30, Pg 100): the headless figure leaves out the
   terminal and is not what a user sees.

Run: ``.venv/bin/python bench/bench_console.py [--repeats N]`` (``make bench`` runs it).
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
TERM_SIZE = (160, 50)
"""Columns × rows of the real-terminal measurements (the size the issue measured at)."""
TMUX_POLL_S = 0.1
"""How often the tmux screen is read while waiting (the figures are ±this per run)."""


def private_data() -> Path:
    """A temporary copy of the demo data (the console writes its .OUT next to the .RUN), with
    pace fast and LOPReject N (no question may stop a timed run)."""
    target = Path(tempfile.mkdtemp(prefix="uvnav-bench-"))
    for name in DATA_FILES:
        shutil.copy(ROOT / "data" / name, target / name)
    toml = target / "DEMO.toml"
    text = toml.read_text(encoding="utf-8")
    text = text.replace('pace = "real"', 'pace = "fast"').replace(
        "[lsq]\n", '[lsq]\nlop_reject = "N"\n', 1)
    if 'pace = "fast"' not in text or 'lop_reject = "N"' not in text:
        raise SystemExit("bench: cannot set pace/lop_reject in the private DEMO.toml")
    toml.write_text(text, encoding="utf-8")
    return target


def startup_once(config: Path, timeout_s: float = 30.0, pycache: Path | None = None) -> float:
    """Seconds from spawning ``uvnav`` in a pty until the menu bar is painted; ``pycache`` is
    the bytecode cache directory to use (``PYTHONPYCACHEPREFIX``)."""
    cols, rows = TERM_SIZE
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", rows, cols, 0, 0))
    env = dict(os.environ, TERM="xterm-256color", COLUMNS=str(cols), LINES=str(rows))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # else the "warm" cache is never written
    if pycache is not None:
        env["PYTHONPYCACHEPREFIX"] = str(pycache)
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "uvnav_tui.cli.main", "--config", str(config),
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


def engine_rate(config: Path, *, out: bool = False, cpu: bool = False) -> float:
    """Cycles/s of the bare engine over the whole demo (with smoother collection, as the
    console runs it); ``out``: the ``.OUT`` written too (as the console does: the fair
    comparison); ``cpu``: per CPU-second (``time.process_time``) instead of wall-clock."""
    from engine.run.session import Session

    out_path = config.parent / "ENGINE.OUT" if out else None
    session = Session.from_file(config, collect_smoother=True, out_path=out_path, force=True)
    clock = time.process_time if cpu else time.perf_counter
    t0 = clock()
    n = 0
    try:
        while session.step() is not None:
            n += 1
        return n / (clock() - t0)
    finally:
        session.close()


async def _console_rate(config: Path) -> tuple[float, int]:
    from engine.run.config import load_config
    from uvnav_tui.app import UVNAVApp

    # The demo asks "Discard LOP?" 6 times (LOPReject = A, the thesis default); the app answers
    # "no" itself, as `uvnav script` answers with `lop`, so an unanswered question cannot stall
    # the run (it did: make bench hung at the first one).
    app = UVNAVApp(load_config(config), pace_override="fast", write_logs=False,
                   hardcopy_dir=config.parent / "hardcopy", lop_policy="no")
    async with app.run_test(size=(100, 30)) as pilot:
        await pilot.pause()
        # The clock starts before the key: the pilot's press waits for the app to be idle,
        # which at pace fast can be after many cycles (on 2026-12-04 after the whole run:
        # "5940594473 cycles/s").
        t0 = time.perf_counter()
        await pilot.press("enter")
        assert app.control is not None
        while not app.control.eof:
            await asyncio.sleep(0.01)
        elapsed = time.perf_counter() - t0
        return app.control.cycles / elapsed, app.control.cycles


def console_rate(config: Path) -> float:
    """Cycles/s of the headless console at "fast" with the main page visible."""
    rate, _n = asyncio.run(_console_rate(config))
    return rate


# --------------------------------------------------------------------------- real terminal
def _tmux(*args: str) -> str:
    return subprocess.run(["tmux", *args], check=True, capture_output=True,
                          text=True).stdout


def _new_session(session: str, cols: int, rows: int, cmd: str, tries: int = 3) -> None:
    """A detached tmux session running ``cmd``. Retried after a short pause: when the previous
    run's session was the server's last, the server may still be exiting and refuse the new
    session (seen in make bench on 2026-12-03: the Pg 642 run after the Pg 100 runs failed)."""
    for k in range(tries):
        try:
            _tmux("new-session", "-d", "-s", session, "-x", str(cols), "-y", str(rows), cmd)
            return
        except subprocess.CalledProcessError as exc:
            if k == tries - 1:
                raise RuntimeError(f"tmux new-session failed {tries} times: {exc.stderr}") from exc
            time.sleep(0.5)


def _wait_screen(session: str, needle: str, timeout_s: float) -> bool:
    """True once ``needle`` is on the tmux screen; False after ``timeout_s`` or if the
    session has ended."""
    deadline = time.perf_counter() + timeout_s
    while time.perf_counter() < deadline:
        try:
            if needle in _tmux("capture-pane", "-p", "-t", session):
                return True
        except subprocess.CalledProcessError:
            return False
        time.sleep(TMUX_POLL_S)
    return False


def _thread_cpu(pid: int) -> dict[str, float]:
    """CPU seconds (user + system) of each thread of process ``pid`` (Linux ``/proc``; empty
    elsewhere)."""
    tick = os.sysconf("SC_CLK_TCK")
    out: dict[str, float] = {}
    try:
        for tid in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{tid}/stat", encoding="ascii") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            out[tid] = (int(fields[11]) + int(fields[12])) / tick
    except OSError:
        pass
    return out


def tmux_run(config: Path, page: int, timeout_s: float = 600.0) -> tuple[float, float, float]:
    """The whole demo at pace fast in a detached tmux session of :data:`TERM_SIZE`, showing
    ``page`` (typed as its number right after the start): (cycles per wall-clock second,
    cycles per CPU-second of the console process, the UI thread's share of that CPU time);
    NaN when it failed.  The CPU figures do not depend on what else the machine runs."""
    cols, rows = TERM_SIZE
    session = f"uvnav-bench-{os.getpid()}"
    cmd = (f"cd {config.parent} && PYTHONPATH={ROOT} exec {sys.executable} -m uvnav_tui.cli.main "
           f"--config {config} --hardcopy-dir {config.parent / 'hardcopy'}")
    _new_session(session, cols, rows, cmd)
    nan = float("nan")
    try:
        pid = int(_tmux("display", "-p", "-t", session, "#{pane_pid}").strip())
        if not _wait_screen(session, "Parameter Initialization", 60.0):
            return nan, nan, nan
        before = _thread_cpu(pid)
        _tmux("send-keys", "-t", session, "Enter")
        t0 = time.perf_counter()
        if page != 100:
            _tmux("send-keys", "-t", session, *str(page))
        if not _wait_screen(session, "End of data file", timeout_s):
            return nan, nan, nan
        elapsed = time.perf_counter() - t0
        after = _thread_cpu(pid)
        screen = _tmux("capture-pane", "-p", "-t", session)
        if f"Pg {page}" not in screen:
            return nan, nan, nan
        used = {tid: t - before.get(tid, 0.0) for tid, t in after.items()}
        total = sum(used.values())
        ui = used.get(str(pid), nan)  # the main thread's id is the process id
        if total <= 0.0:
            return 7200 / elapsed, nan, nan
        return 7200 / elapsed, 7200 / total, ui / total
    finally:
        subprocess.run(["tmux", "kill-session", "-t", session], capture_output=True)


def tmux_rate(config: Path, page: int, timeout_s: float = 600.0) -> float:
    """Cycles/s of the whole demo at pace fast in a detached tmux session of
    :data:`TERM_SIZE`, showing ``page`` (typed as its number right after the start)."""
    return tmux_run(config, page, timeout_s)[0]


def tmux_keys(config: Path, tries: int = 10) -> tuple[int, int]:
    """Alt+T then L sent in one write (as fast as a terminal can deliver them) during a run at
    pace fast, ``tries`` times: (hits, tries made while the run was working).  A hit is
    Statistics ▸ LSE (Pg 631) shown with no menu left open; between tries ``100`` returns to
    the main page."""
    cols, rows = TERM_SIZE
    session = f"uvnav-keys-{os.getpid()}"
    cmd = (f"cd {config.parent} && PYTHONPATH={ROOT} exec {sys.executable} -m uvnav_tui.cli.main "
           f"--config {config} --hardcopy-dir {config.parent / 'hardcopy'}")
    _new_session(session, cols, rows, cmd)
    hits = made = 0
    try:
        if not _wait_screen(session, "Parameter Initialization", 60.0):
            return 0, 0
        _tmux("send-keys", "-t", session, "Enter")
        if not _wait_screen(session, "Working...", 60.0):
            return 0, 0
        for _ in range(tries):
            _tmux("send-keys", "-t", session, "M-t", "l")
            ok = _wait_screen(session, "Pg 631", 10.0)
            screen = _tmux("capture-pane", "-p", "-t", session)
            if "End of data file" in screen:
                break
            made += 1
            hits += ok and "Pg 631" in screen.splitlines()[1]
            _tmux("send-keys", "-t", session, "Escape", "1", "0", "0")
            _wait_screen(session, "Pg 100", 10.0)
        return hits, made
    finally:
        subprocess.run(["tmux", "kill-session", "-t", session], capture_output=True)


def _median(xs: list[float], decimals: int = 2) -> str:
    good = [x for x in xs if x == x]
    return f"{statistics.median(good):.{decimals}f}" if good else "n/a"


def main() -> None:
    """Run the benchmarks and print the medians."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    data = private_data()
    config = data / "DEMO.toml"
    cols, rows = TERM_SIZE
    console_cpu: dict[int, str] = {}
    print(f"console, real terminal {cols}×{rows}, {os.cpu_count()} CPU(s), load average "
          f"{os.getloadavg()[0]:.1f} at the start, Python {sys.version.split()[0]}")
    cold = []
    for _ in range(args.repeats):
        with tempfile.TemporaryDirectory(prefix="uvnav-pycache-") as empty:
            cold.append(startup_once(config, pycache=Path(empty)))
    with tempfile.TemporaryDirectory(prefix="uvnav-pycache-") as cache:
        startup_once(config, pycache=Path(cache))  # fills the cache
        warm = [startup_once(config, pycache=Path(cache)) for _ in range(args.repeats)]
    print(f"first paint (pty), no bytecode cache: median {_median(cold)} s "
          f"(runs: {', '.join(f'{s:.2f}' for s in cold)})")
    print(f"first paint (pty), warm bytecode cache: median {_median(warm)} s "
          f"(runs: {', '.join(f'{s:.2f}' for s in warm)})")
    if shutil.which("tmux") is None:
        print("tmux not found: the real-terminal cycle rates are skipped")
    else:
        for page in (100, 642):
            runs = [tmux_run(config, page) for _ in range(args.repeats)]
            rates, cpu_rates, ui = zip(*runs, strict=True)
            print(f"console in tmux {cols}×{rows} at pace fast, Pg {page}: median "
                  f"{_median(list(rates), 0)} cycles/s (runs: "
                  f"{', '.join(f'{r:.0f}' for r in rates)}); {_median(list(cpu_rates), 0)} "
                  f"cycles per CPU-second of the process, UI thread "
                  f"{_median([100 * u for u in ui], 0)} % of it")
            console_cpu[page] = _median(list(cpu_rates), 0)
        hits, made = tmux_keys(config)
        print(f"keys in tmux at pace fast: Alt+T L in one write took effect {hits} of {made} "
              "times")
    engine = [engine_rate(config) for _ in range(args.repeats)]
    print(f"bare engine, demo 7200 records: median {statistics.median(engine):.0f} cycles/s")
    engine_out = [engine_rate(config, out=True) for _ in range(args.repeats)]
    engine_cpu = [engine_rate(config, out=True, cpu=True) for _ in range(args.repeats)]
    med_cpu = statistics.median(engine_cpu)
    print(f"bare engine with the .OUT written (the console's work): median "
          f"{statistics.median(engine_out):.0f} cycles/s, {med_cpu:.0f} cycles per CPU-second")
    for page, rate in console_cpu.items():
        if rate != "n/a":
            print(f"console / engine alone (CPU time, .OUT both), Pg {page}: "
                  f"{float(rate) / med_cpu:.2f}")
    console = [console_rate(config) for _ in range(args.repeats)]
    print(f"console headless (no terminal, 100×30) at pace fast, Pg 100: median "
          f"{statistics.median(console):.0f} cycles/s "
          f"(runs: {', '.join(f'{c:.0f}' for c in console)})")
    shutil.rmtree(data, ignore_errors=True)


if __name__ == "__main__":
    main()
