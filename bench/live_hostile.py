"""Hostile live input against ``uvnav live`` in its own process: flood, trickle, reconnect storm
and wild clocks (no assertions; prints what each cost; docs/LIVE.md "Under overload").

Each case starts ``.venv/bin/uvnav live … --quiet`` as a child process with a ``--seconds``
limit, plays its input from this process (the UDP flood from a sender *process*, so it has a
core of its own) on 127.0.0.1 only, and reports from the child's own accounting (its summary)
and the kernel's (``wait4``: CPU seconds, peak RSS):

* **flood**: ``--rate`` valid one-sentence datagrams a second for ``--flood-s`` seconds (a 1 Hz
  stream's GGA, RMC, HDT, VHW played ever faster), then one more after a pause, which carries
  the system's drop count. Reported: sent, received, dropped by UVNAV, dropped by the system,
  whether they add up, peak RSS, CPU, how long past ``--seconds`` the run took, raw-log and
  times-file sizes.
* **tcpflood**: a TCP server sends a 1 Hz stream's lines as fast as the connection takes them
  for ``--flood-s`` seconds: sent, run, dropped, peak RSS, CPU.
* **trickle**: a TCP server sends 200 valid lines, then one byte a second without a line end:
  when the run says the source is lost (``--lost-after 5``).
* **storm**: a TCP server that accepts and closes at once, for 20 s: connections made, CPU,
  times-file size.
* **clock**: a 10 Hz stream (stream time: 1 s per 0.1 s) with a ZDA dated 2099, a GGA
  ``235960`` at noon and an RMC a year ahead among its sentences, each once; then the stream
  restarted 100 s earlier (a real jump back): cycles run, sentences skipped, whether the stall
  was said.

Run: ``.venv/bin/python bench/live_hostile.py [flood|tcpflood|trickle|storm|clock ...] [--rate
N] [--flood-s S]`` (all five by default: about 2 minutes, two cores busy during the floods).
Not part of ``make bench``: it loads the machine on purpose.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import re
import resource
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from tests.nmea_lines import ddmm, hhmmss, nmea  # noqa: E402

UVNAV = ROOT / ".venv" / "bin" / "uvnav"
LAT0 = 52.8333333333
LON0 = 4.5
T0 = 43200


def second_lines(k: int, day: str = "021226") -> list[str]:
    """Second ``k`` of a vessel steaming north at 5 kn: GGA, RMC, HDT, VHW."""
    t = (T0 + k) % 86400
    lat = LAT0 + k * 5.0 / 216000.0
    return [
        nmea(f"GPGGA,{hhmmss(t)},{ddmm(lat)},N,{ddmm(LON0, 3)},E,1,09,0.8,3.0,M,46.0,M,,"),
        nmea(f"GPRMC,{hhmmss(t)},A,{ddmm(lat)},N,{ddmm(LON0, 3)},E,5.0,0.0,{day},,,A"),
        nmea("HEHDT,0.0,T"),
        nmea("VWVHW,,T,,M,5.0,N,,K"),
    ]


def config(directory: Path) -> Path:
    path = directory / "hostile.toml"
    path.write_text(
        'datum = "WGS84"\ndr_position = "52 50 00 N 004 30 00 E"\nrun_file = "unused.RUN"\n'
        f'run_gps_datum = "WGS84"\ndata_dir = "{ROOT / "data"}"\n[gps]\non = true\n'
        "[decca]\non = false\n")
    return path


def free_port(kind: int) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_bound_udp(port: int, limit_s: float = 30.0) -> None:
    end = time.monotonic() + limit_s
    while time.monotonic() < end:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind(("127.0.0.1", port))
            except OSError:
                return
        time.sleep(0.05)
    raise RuntimeError(f"nobody bound UDP {port}")


class Child:
    """``uvnav live ARGS`` in a child process; :meth:`wait` gives its output, CPU and peak
    RSS (``wait4``)."""

    def __init__(self, args: list[str], cwd: Path) -> None:
        self.start = time.monotonic()
        self.proc = subprocess.Popen([str(UVNAV), "live", *args, "--quiet"], cwd=cwd,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True)
        self.lines: list[tuple[float, str]] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append((time.monotonic() - self.start, line.rstrip("\n")))

    def wait(self) -> tuple[int, float, float, float]:
        """Exit status, wall seconds, CPU seconds, peak RSS [MB]."""
        _pid, status, usage = os.wait4(self.proc.pid, 0)
        wall = time.monotonic() - self.start
        self.proc.returncode = os.waitstatus_to_exitcode(status)
        self._reader.join(10.0)
        return (self.proc.returncode, wall, usage.ru_utime + usage.ru_stime,
                usage.ru_maxrss / 1024.0)

    @property
    def text(self) -> str:
        return "\n".join(t for _s, t in self.lines)


def _flood_sender(port: int, rate: float, seconds: float, sent: multiprocessing.Value) -> None:
    """Datagrams at ``rate`` a second for ``seconds`` (in batches of 100), then one more after
    a pause of 1 s; the count in ``sent``."""
    datagrams = [(s + "\r\n").encode() for k in range(2000) for s in second_lines(k)]
    n = 0
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
        out.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 1 << 20)
        target = ("127.0.0.1", port)
        start = time.monotonic()
        while (now := time.monotonic()) - start < seconds:
            due = n / rate
            if now - start < due:
                time.sleep(min(due - (now - start), 0.01))
                continue
            for _ in range(100):
                try:
                    out.sendto(datagrams[n % len(datagrams)], target)
                except OSError:  # ENOBUFS: not sent, not counted
                    continue
                n += 1
        time.sleep(1.0)
        out.sendto(datagrams[0], target)
        n += 1
    sent.value = n


def _summary_counts(text: str) -> dict[str, int]:
    out: dict[str, int] = {}
    m = re.search(r"lines received (\d+)", text)
    if m:
        out["received"] = int(m.group(1))
    m = re.search(r"lines dropped (\d+) \(by UVNAV (\d+) when waiting lines were full, "
                  r"datagrams by the system (\d+)\), received after the end (\d+)", text)
    if m:
        out["dropped"], out["uvnav"], out["system"], out["unrun"] = map(int, m.groups())
    return out


def case_flood(rate: float, seconds: float) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        port = free_port(socket.SOCK_DGRAM)
        limit = seconds + 5.0
        child = Child([f"udp://127.0.0.1:{port}", "--config", str(config(d)), "--out",
                       "F.OUT", "--seconds", f"{limit:g}"], d)
        wait_bound_udp(port)
        sent = multiprocessing.Value("q", 0)
        sender = multiprocessing.Process(target=_flood_sender, args=(port, rate, seconds, sent))
        sender.start()
        sender.join()
        status, wall, cpu, rss = child.wait()
        c = _summary_counts(child.text)
        got = c.get("received", 0) + c.get("unrun", 0)
        total = got + c.get("uvnav", 0) + c.get("system", 0)
        raw = sum(p.stat().st_size for p in d.glob("F*.raw.nmea"))
        times = sum(p.stat().st_size for p in d.glob("F*.raw.times.csv"))
        print(f"flood {rate:.0f}/s for {seconds:g} s: sent {sent.value}, run {c.get('received')}"
              f", after the end {c.get('unrun')}, dropped by UVNAV {c.get('uvnav')}, by the "
              f"system {c.get('system')}; accounted {total} of {sent.value} "
              f"({'all' if total == sent.value else 'MISSING ' + str(sent.value - total)})")
        print(f"  exit {status}, --seconds {limit:g} took {wall:.1f} s, CPU {cpu:.1f} s, "
              f"peak RSS {rss:.0f} MB, raw log {raw / 1e6:.1f} MB, times {times / 1e3:.0f} kB "
              f"({len(list(d.glob('F*.raw.nmea')))} part(s))")
        for _s, line in child.lines:
            if "overloaded" in line:
                print(f"  first overload line: {line[:110]}")
                break


def case_tcpflood(seconds: float) -> None:
    """A TCP server that sends as fast as the connection takes for ``seconds``."""
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        listener = socket.create_server(("127.0.0.1", 0))
        port = listener.getsockname()[1]
        limit = seconds + 5.0
        child = Child([f"tcp://127.0.0.1:{port}", "--config", str(config(d)), "--out", "P.OUT",
                       "--seconds", f"{limit:g}"], d)
        listener.settimeout(20.0)
        conn, _ = listener.accept()
        lines = [s for k in range(2000) for s in second_lines(k)]
        block = "".join(s + "\r\n" for s in lines).encode()
        sent = 0
        with conn:
            start = time.monotonic()
            while time.monotonic() - start < seconds:
                conn.sendall(block)
                sent += len(lines)
            status, wall, cpu, rss = child.wait()
        listener.close()
        c = _summary_counts(child.text)
        got = c.get("received", 0) + c.get("unrun", 0) + c.get("uvnav", 0)
        whole = "all" if got == sent else f"MISSING {sent - got}"
        print(f"tcp flood for {seconds:g} s: sent {sent} lines ({sent / seconds:.0f}/s), run "
              f"{c.get('received')}, after the end {c.get('unrun')}, dropped by UVNAV "
              f"{c.get('uvnav')}; accounted {got} ({whole}); exit {status}, --seconds "
              f"{limit:g} took {wall:.1f} s, CPU {cpu:.1f} s, peak RSS {rss:.0f} MB")


def case_trickle() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        listener = socket.create_server(("127.0.0.1", 0))
        port = listener.getsockname()[1]
        child = Child([f"tcp://127.0.0.1:{port}", "--config", str(config(d)), "--out", "T.OUT",
                       "--seconds", "16", "--lost-after", "5"], d)
        listener.settimeout(20.0)
        conn, _ = listener.accept()
        lines = [s for k in range(50) for s in second_lines(k)]
        conn.sendall("".join(s + "\r\n" for s in lines).encode())
        sent_at = time.monotonic() - child.start
        with conn:
            for _ in range(14):
                time.sleep(1.0)
                try:
                    conn.sendall(b"$")
                except OSError:
                    break
            status, wall, cpu, rss = child.wait()
        listener.close()
        lost = [(s, t) for s, t in child.lines if "source lost" in t]
        when = f"{lost[0][0] - sent_at:.1f} s after the last line: {lost[0][1][10:]}" \
            if lost else "NEVER"
        print(f"trickle: 200 lines then 1 byte/s: lost {when}; exit {status}, CPU {cpu:.1f} s, "
              f"peak RSS {rss:.0f} MB")


def case_storm() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        listener = socket.create_server(("127.0.0.1", 0))
        listener.settimeout(0.05)
        port = listener.getsockname()[1]
        child = Child([f"tcp://127.0.0.1:{port}", "--config", str(config(d)), "--out", "S.OUT",
                       "--seconds", "20"], d)
        accepted = 0
        while time.monotonic() - child.start < 23.0:  # the run's 20 s and its start-up
            try:
                conn, _ = listener.accept()
            except TimeoutError:
                continue
            accepted += 1
            conn.close()
        status, wall, cpu, rss = child.wait()
        listener.close()
        times = sum(p.stat().st_size for p in d.glob("S*.raw.times.csv"))
        print(f"storm: accept-and-close for {wall:.0f} s: {accepted} connections, exit {status}, "
              f"CPU {cpu:.1f} s, peak RSS {rss:.0f} MB, times file {times} bytes")


def case_clock() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        port = free_port(socket.SOCK_DGRAM)
        child = Child([f"udp://127.0.0.1:{port}", "--config", str(config(d)), "--out", "C.OUT",
                       "--seconds", "14"], d)
        wait_bound_udp(port)
        wild = {20: nmea("GPZDA,120020.50,02,12,2099,00,00"),
                40: nmea("GPGGA,235960,5250.0000,N,00430.0000,E,1,07,1.2,2.0,M,46.0,M,,"),
                60: second_lines(60, "021227")[1]}
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
            for k in [*range(80), *range(-20, 40)]:  # 80 s, then restarted 100 s earlier
                lines = second_lines(k)
                if k in wild and k >= 0:
                    lines.insert(1, wild.pop(k))
                out.sendto("".join(s + "\r\n" for s in lines).encode(), ("127.0.0.1", port))
                time.sleep(0.1)
        status, wall, cpu, rss = child.wait()
        text = child.text
        epochs = re.search(r"^epochs (\d+)", text, re.M)
        skipped = re.search(r"^nmea: skipped: (.*)$", text, re.M)
        said = [t for t in text.splitlines() if "CLOCK BEHIND" in t]
        print(f"clock: 80 s with a ZDA of 2099, a 235960 at noon and an RMC a year ahead, then "
              f"restarted 100 s back: epochs {epochs.group(1) if epochs else '?'} (80 expected "
              f"before the restart, and the restart's after 12:01:19), skipped "
              f"{skipped.group(1) if skipped else 'nothing'}; stall said: "
              f"{said[0][10:80] if said else 'NO'}; exit {status}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("cases", nargs="*",
                   default=["flood", "tcpflood", "trickle", "storm", "clock"])
    p.add_argument("--rate", type=float, default=100_000.0, help="flood datagrams a second")
    p.add_argument("--flood-s", type=float, default=15.0, help="flood seconds")
    args = p.parse_args()
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    print(f"{time.strftime('%Y-%m-%d %H:%M', time.gmtime())}Z, load "
          f"{os.getloadavg()[0]:.1f}, {os.cpu_count()} cores")
    for case in args.cases:
        if case == "flood":
            case_flood(args.rate, args.flood_s)
        elif case == "tcpflood":
            case_tcpflood(args.flood_s)
        elif case == "trickle":
            case_trickle()
        elif case == "storm":
            case_storm()
        elif case == "clock":
            case_clock()
        else:
            raise SystemExit(f"unknown case {case!r}")


if __name__ == "__main__":
    main()
