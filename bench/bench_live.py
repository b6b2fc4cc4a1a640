"""Live-stream latency: from a sentence received on the socket to the position available
(no assertions; prints medians with the conditions; docs/LIVE.md "Latency").

A sender thread plays a synthetic 1 Hz NMEA stream (each second: GGA, RMC, HDT, VHW in one UDP
datagram, as multiplexers send) to ``uvnav``'s live run in this process
(:func:`engine.api.open_live_run`, ``.OUT`` and raw log written to a temporary directory, as
``uvnav live`` does). For every cycle it measures, on one monotonic clock:

* **processing**: from the receipt of the line that closed the epoch (the first sentence of
  the next second, engine/io/nmea_epochs.py) to the cycle's result logged;
* **end to end**: from the receipt of the epoch's own GGA to the cycle's result: the wait for
  the closing sentence (one send interval) plus the processing;
* **socket**: from ``sendto`` to the receipt (the reader thread's timestamp).

``--console`` measures the console instead (Textual's headless driver, no terminal): from the
epoch's GGA received to the main page repainted with that cycle (``refresh_display`` done,
which the console throttles to 10 Hz, as in a terminal; Textual's own frame comes after it).

Run: ``.venv/bin/python bench/bench_live.py [--epochs N] [--rate HZ] [--console]`` (``make
bench`` runs it with 60 epochs at 1 Hz, the pace of a real receiver, and 600 at 20 Hz).
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from engine.api import load_run_config, open_live_run  # noqa: E402
from tests.nmea_lines import ddmm, hhmmss, nmea  # noqa: E402

LAT0 = 52.8333333333
LON0 = 4.5
T0 = 43200
LINES_PER_EPOCH = 4


def epoch_datagram(k: int) -> bytes:
    """Second ``k`` of a vessel steaming north at 5 kn: GGA, RMC, HDT, VHW (CR LF each)."""
    t = T0 + k
    lat = LAT0 + k * 5.0 / 216000.0
    lines = [
        nmea(f"GPGGA,{hhmmss(t)},{ddmm(lat)},N,{ddmm(LON0, 3)},E,1,09,0.8,3.0,M,46.0,M,,"),
        nmea(f"GPRMC,{hhmmss(t)},A,{ddmm(lat)},N,{ddmm(LON0, 3)},E,5.0,0.0,021226,,,A"),
        nmea("HEHDT,0.0,T"),
        nmea("VWVHW,,T,,M,5.0,N,,K"),
    ]
    return "".join(s + "\r\n" for s in lines).encode()


def _config(directory: Path) -> Path:
    path = directory / "bench.toml"
    path.write_text(
        'datum = "WGS84"\ndr_position = "52 50 00 N 004 30 00 E"\nrun_file = "unused.RUN"\n'
        f'run_gps_datum = "WGS84"\ndata_dir = "{ROOT / "data"}"\n[gps]\non = true\n'
        "[decca]\non = false\n")
    return path


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def measure(epochs: int, rate_hz: float) -> dict[str, list[float]]:
    """Latencies [s] of ``epochs`` cycles with the stream sent at ``rate_hz`` epochs/s."""
    with tempfile.TemporaryDirectory() as tmp:
        cfg, data = load_run_config(_config(Path(tmp)))
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.bind(("127.0.0.1", 0))
            port = probe.getsockname()[1]
        run = open_live_run(f"udp://127.0.0.1:{port}", cfg, data, out_path=Path(tmp) / "B.OUT",
                            history=1)
        sent: dict[int, float] = {}
        stop = threading.Event()

        def sender() -> None:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
                start = time.monotonic()
                for k in range(epochs + 1):
                    due = start + k / rate_hz
                    if stop.wait(max(0.0, due - time.monotonic())):
                        return
                    sent[k] = time.monotonic()
                    out.sendto(epoch_datagram(k), ("127.0.0.1", port))

        thread = threading.Thread(target=sender)
        result: dict[str, list[float]] = {"processing": [], "end to end": [], "socket": []}
        try:
            thread.start()
            deadline = time.monotonic() + epochs / rate_hz + 60.0
            while run.cycles < epochs and time.monotonic() < deadline:
                for c in run.poll(0.5).cycles:
                    k = round(c.result.time.timestamp()) % 86400 - T0  # second of the stream
                    gga = run.feed.received_mono_s(k * LINES_PER_EPOCH + 1)
                    result["processing"].append(c.latency_s)
                    if gga is not None:
                        result["end to end"].append(c.done_mono_s - gga)
                        if k in sent:
                            result["socket"].append(gga - sent[k])
        finally:
            stop.set()
            thread.join()
            run.close()
    return result


def measure_console(epochs: int, rate_hz: float) -> dict[str, list[float]]:
    """GGA received → main page repainted with its cycle [s], console in the headless driver."""
    import asyncio

    from engine.api import load_config
    from uvnav_tui import app as app_module
    from uvnav_tui.app import UVNAVApp

    # The headless driver repaints at most every 0.5 s (nobody watches); a terminal every 0.1 s:
    # measure with the terminal's throttle.
    app_module.HEADLESS_REFRESH_S = app_module.REFRESH_S

    shown: dict[int, float] = {}

    with tempfile.TemporaryDirectory() as tmp:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.bind(("127.0.0.1", 0))
            port = probe.getsockname()[1]
        cfg = load_config(_config(Path(tmp))).replace(run_file=f"udp://127.0.0.1:{port}")
        app = UVNAVApp(cfg, show_init=False, hardcopy_dir=Path(tmp))
        repaint = app.refresh_display

        def timed_refresh(**kw: bool) -> None:  # the instance's repaint, timed (all callers)
            repaint(**kw)
            run = app.control
            if run is not None and run.latest is not None and app.page == 100:
                shown.setdefault(run.latest.n, time.monotonic())

        app.refresh_display = timed_refresh  # type: ignore[method-assign]
        result: dict[str, list[float]] = {"to screen": []}

        async def script() -> None:
            async with app.run_test(size=(160, 50)) as pilot:
                assert app.start_run(app.base_config) is None
                with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
                    start = time.monotonic()
                    for k in range(epochs + 1):
                        await asyncio.sleep(max(0.0, start + k / rate_hz - time.monotonic()))
                        out.sendto(epoch_datagram(k), ("127.0.0.1", port))
                await pilot.pause(1.0)
                control = app.control
                assert control is not None and control.live is not None
                for n, t_shown in shown.items():
                    gga = control.live.feed.received_mono_s((n - 1) * LINES_PER_EPOCH + 1)
                    if gga is not None:
                        result["to screen"].append(t_shown - gga)
                app.stop_run()

        asyncio.run(script())
    return result


def report(epochs: int, rate_hz: float, console: bool = False) -> None:
    """Print the medians (and 95th percentiles, maxima) of one measurement."""
    res = measure_console(epochs, rate_hz) if console else measure(epochs, rate_hz)
    n = len(next(iter(res.values())))
    where = "console (headless driver)" if console else "engine"
    print(f"live latency, {where}, UDP localhost, {n} cycles at {rate_hz:g} epochs/s "
          f"(load average {os.getloadavg()[0]:.1f}, Python {sys.version.split()[0]}):")
    for name, values in res.items():
        if values:
            print(f"  {name:>10}: median {statistics.median(values) * 1e3:8.2f} ms   "
                  f"p95 {_pct(values, 0.95) * 1e3:8.2f} ms   max {max(values) * 1e3:8.2f} ms")


def main(argv: list[str] | None = None) -> None:
    """``make bench`` entry: 60 epochs at 1 Hz and 600 at 20 Hz unless told otherwise."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--epochs", type=int)
    p.add_argument("--rate", type=float, help="epochs sent per second (1 = real time)")
    p.add_argument("--console", action="store_true", help="measure to the console's screen")
    args = p.parse_args(argv if argv is not None else sys.argv[1:] if __name__ == "__main__"
                        else [])
    if args.epochs or args.rate or args.console:
        report(args.epochs or 60, args.rate or 1.0, args.console)
        return
    report(60, 1.0)
    report(600, 20.0)
    report(60, 1.0, console=True)


if __name__ == "__main__":
    main()
