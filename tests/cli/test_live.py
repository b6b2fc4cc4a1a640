"""``uvnav live``: a sender thread replays an NMEA log over real localhost sockets (UDP, and a
TCP server that dies mid-stream and comes back), the command runs the cycles (docs/LIVE.md).

Expected values come from the test's own log: the GPS position of every epoch is computed here
(a vessel steaming north at 5 kn: 5/60 ′ of latitude a minute), the raw log must hold the sent
lines byte for byte, and replaying the raw log with ``uvnav replay`` must give the same cycles
as the live run. Waits are on events and deadlines, generous for a loaded 2-core machine.
"""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from engine.io.outlog import read_out_log
from tests.live_helpers import (
    DEADLINE_S,
    LON0,
    epoch_lines,
    expected_lat,
    free_port,
    send_udp,
    wait_bound_udp,
    write_config,
)
from tests.nmea_lines import nmea
from tests.paths import ROOT
from uvnav_tui.cli.main import main


def cycle_lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if ln.startswith("#")]


def test_live_udp_end_to_end(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = write_config(tmp_path / "boat.toml")
    port = free_port(socket.SOCK_DGRAM)
    stop = threading.Event()
    n = 20
    sender = threading.Thread(target=send_udp, args=(port, range(n + 1), stop))
    sender.start()
    try:
        status = main(["live", f"udp://127.0.0.1:{port}", "--config", str(cfg),
                       "--out", str(tmp_path / "L.OUT"), "--cycles", str(n)])
    finally:
        stop.set()
        sender.join()
    out = capsys.readouterr().out
    assert status == 0
    lines = cycle_lines(out)
    assert len(lines) == n
    assert lines[0].startswith("#1 12:00:00Z  52°50'00.000\" N 004°30'00.000\" E WGS84")
    assert "receiving from udp://127.0.0.1:" in out
    assert f"epochs {n}  fixes {n}" in out
    cost = re.search(r"lines received (\d+)\nlines dropped 0 \(by UVNAV 0 when waiting lines "
                     r"were full, datagrams by the system 0\), received after the end (\d+) "
                     r"\(raw log only\), over-long lines 0 \(0 bytes not kept\)", out)
    assert cost is not None, out
    cycles = read_out_log(tmp_path / "L.OUT").cycles
    assert len(cycles) == n
    for k, c in enumerate(cycles):
        gps = c.first("GPS")
        assert gps is not None
        # The GPS latitude the cycle took is the one sent (4 decimals of minutes: 1e-6 deg).
        assert gps["lat_in"] == pytest.approx(expected_lat(k), abs=1e-9)
        assert gps["lon_in"] == pytest.approx(LON0, abs=1e-9)
    # The raw log: every line received, byte for byte, CR LF ended; its receive times.
    raw = (tmp_path / "L.raw.nmea").read_bytes()
    sent_prefix = b"".join((s + "\r\n").encode() for k in range(n + 1) for s in epoch_lines(k))
    assert sent_prefix.startswith(raw) and raw.count(b"\r\n") >= 4 * (n + 1) - 4
    assert raw.count(b"\r\n") == int(cost.group(1)) + int(cost.group(2))
    times = (tmp_path / "L.raw.times.csv").read_text().splitlines()
    rows = [t.split(",") for t in times if t[:1].isdigit()]  # line,lines,utc,mono_s
    assert sum(int(r[1]) for r in rows) == raw.count(b"\r\n")
    assert all(int(b[0]) == int(a[0]) + int(a[1]) for a, b in zip(rows, rows[1:], strict=False))
    # The .OUT header names the URL and the raw log as the run file.
    head = (tmp_path / "L.OUT").read_text().splitlines()[:40]
    assert f"# run udp://127.0.0.1:{port}" in head
    assert f'# run_file = "{tmp_path / "L.raw.nmea"}"' in head
    # Replaying the raw log gives the live run's cycles, line for line.
    assert main(["replay", str(tmp_path / "L.raw.nmea"), "--config", str(cfg),
                 "--out", str(tmp_path / "R.OUT")]) == 0
    live_body = [ln for ln in (tmp_path / "L.OUT").read_text().splitlines()
                 if not ln.startswith("#")]
    replay_body = [ln for ln in (tmp_path / "R.OUT").read_text().splitlines()
                   if not ln.startswith("#")]
    assert replay_body[:len(live_body)] == live_body


def test_live_without_config_derives_one_from_the_stream(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """No --config: DR position = the first fix, GPS on, Decca off, gyro and log on (HDT, VHW
    came), echo sounder n/a (no DBT) — as docs/NMEA.md derives one from a log."""
    port = free_port(socket.SOCK_DGRAM)
    status = live_while_sending(
        send_udp_paced, (port, range(40)),
        ["live", f"udp://127.0.0.1:{port}", "--out", str(tmp_path / "D.OUT"), "--learn", "0.5",
         "--cycles", "30"])
    out = capsys.readouterr().out
    assert status == 0, out
    assert "no --config: waiting for the first fix" in out
    assert "configuration derived from the stream" in out
    assert "DR position 52 50 00.000 N 004 30 00.000 E (the first valid fix)" in out
    assert "GPS on (C/A), Decca off" in out
    assert "sensors: gyro on, log on, echo sounder n/a" in out
    cycles = read_out_log(tmp_path / "D.OUT").cycles
    assert len(cycles) == 30  # the records of the learning seconds are run too: from 12:00:00
    gps = cycles[0].first("GPS")
    assert gps is not None and gps["lat_in"] == pytest.approx(expected_lat(0), abs=1e-9)
    head = (tmp_path / "D.OUT").read_text()
    assert '# datum = "WGS84"' in head and "# [decca]\n# on = false" in head


def live_while_sending(sender_target: Callable[..., None], sender_args: tuple[object, ...],
                       argv: list[str], limit_s: float | None = None) -> int:
    """``uvnav ARGV`` while a sender thread runs ``sender_target(*sender_args, stop)`` (stopped
    and joined after); with ``limit_s`` the command must return within it (:func:`main_within`).
    """
    stop = threading.Event()
    sender = threading.Thread(target=sender_target, args=(*sender_args, stop))
    sender.start()
    try:
        return main(argv) if limit_s is None else main_within(argv, limit_s)
    finally:
        stop.set()
        sender.join()


def main_within(argv: list[str], limit_s: float = DEADLINE_S) -> int:
    """``main(argv)`` in a daemon thread; fails (instead of hanging the suite) when it has not
    returned within ``limit_s``."""
    result: list[int] = []
    worker = threading.Thread(target=lambda: result.append(main(argv)), daemon=True)
    worker.start()
    worker.join(limit_s)
    assert not worker.is_alive(), f"uvnav {' '.join(argv)} still running after {limit_s} s"
    return result[0]


def send_udp_paced(port: int, seconds: range, stop: threading.Event) -> None:
    """:func:`send_udp` with 50 ms between seconds (the learning seconds take real time)."""
    send_udp(port, seconds, stop, 0.05)


def send_headings(port: int, stop: threading.Event) -> None:
    """Only HDT sentences (a heading, never a position), every 50 ms until ``stop``."""
    if not wait_bound_udp(port, stop):
        return
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
        while not stop.wait(0.05):
            out.sendto((epoch_lines(0)[2] + "\r\n").encode(), ("127.0.0.1", port))


def test_live_seconds_ends_the_wait_for_a_first_fix(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """No --config and a stream with no position: --seconds ends the wait (it once waited for
    ever), exit 3, nothing run, the raw log keeps the lines received and is named."""
    port = free_port(socket.SOCK_DGRAM)
    status = live_while_sending(
        send_headings, (port,),
        ["live", f"udp://127.0.0.1:{port}", "--out", str(tmp_path / "N.OUT"), "--seconds", "1.5"],
        30.0)
    err = capsys.readouterr().err
    assert status == 3, err
    assert (f"uvnav live: udp://127.0.0.1:{port}: no position fix within --seconds 1.5 ("
            in err)
    assert "no configuration could be derived, nothing run; raw log " in err
    assert not (tmp_path / "N.OUT").exists()
    raw = (tmp_path / "N.raw.nmea").read_bytes()
    assert raw and set(raw.splitlines()) == {epoch_lines(0)[2].encode()}
    assert str(tmp_path / "N.raw.nmea") in err


def test_live_seconds_cuts_the_learning_short(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """No --config, --learn longer than --seconds: the configuration is derived from what came
    by then, and the learning seconds' records are still run (exit 0)."""
    port = free_port(socket.SOCK_DGRAM)
    status = live_while_sending(
        send_udp_paced, (port, range(40)),
        ["live", f"udp://127.0.0.1:{port}", "--out", str(tmp_path / "C.OUT"), "--learn", "600",
         "--seconds", "1.5"], 30.0)
    out = capsys.readouterr().out
    assert status == 0, out
    assert "configuration derived from the stream" in out
    cycles = read_out_log(tmp_path / "C.OUT").cycles
    assert len(cycles) >= 1
    gps = cycles[0].first("GPS")
    assert gps is not None and gps["lat_in"] == pytest.approx(expected_lat(0), abs=1e-9)
    assert len(cycle_lines(out)) == len(cycles)


class DyingServer:
    """A TCP NMEA server on localhost: sends seconds ``first``, dies, comes back on the same
    port after ``down_s`` and sends ``second`` to the reconnected client."""

    def __init__(self, port: int, first: range, second: range, down_s: float) -> None:
        self.port = port
        self.first, self.second, self.down_s = first, second, down_s
        self.stop = threading.Event()
        self.reconnected = threading.Event()
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run)

    def _serve(self, seconds: range) -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as listener:
            listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            listener.bind(("127.0.0.1", self.port))
            listener.listen(1)
            listener.settimeout(DEADLINE_S)
            client, _ = listener.accept()
            with client:
                for k in seconds:
                    client.sendall("".join(s + "\r\n" for s in epoch_lines(k)).encode())
                    if self.stop.wait(0.01):
                        return
                time.sleep(0.2)  # let the client read before the connection is dropped

    def _run(self) -> None:
        try:
            self._serve(self.first)
            if self.stop.wait(self.down_s):  # nobody listens: connection refused
                return
            self.reconnected.set()
            self._serve(self.second)
        except BaseException as exc:  # reported by the test
            self.error = exc


def test_live_tcp_source_lost_and_reconnected(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    cfg = write_config(tmp_path / "boat.toml")
    port = free_port(socket.SOCK_STREAM)
    server = DyingServer(port, range(0, 10), range(10, 25), down_s=1.0)
    server.thread.start()
    try:
        status = main(["live", f"tcp://127.0.0.1:{port}", "--config", str(cfg),
                       "--out", str(tmp_path / "T.OUT"), "--cycles", "22"])
    finally:
        server.stop.set()
        server.thread.join()
    assert server.error is None
    out = capsys.readouterr().out
    assert status == 0
    lost = [i for i, ln in enumerate(out.splitlines()) if " source lost: " in ln]
    back = [i for i, ln in enumerate(out.splitlines()) if " reconnected: " in ln]
    assert lost and back and lost[0] < back[0], out
    assert "receiving again after" in out.splitlines()[back[0]]
    # Cycles continue across the loss: seconds 0 … 21, none twice, none lost but the gap's.
    cycles = read_out_log(tmp_path / "T.OUT").cycles
    assert len(cycles) == 22
    lats = [c.first("GPS")["lat_in"] for c in cycles]  # type: ignore[index]
    assert lats == pytest.approx([expected_lat(k) for k in range(22)], abs=1e-9)
    times = (tmp_path / "T.raw.times.csv").read_text()
    assert " lost: " in times and " receiving" in times


def test_live_ctrl_c_keeps_every_cycle(tmp_path: Path) -> None:
    """SIGINT to a real process: exit 130, every printed cycle is in the .OUT log."""
    cfg = write_config(tmp_path / "boat.toml")
    port = free_port(socket.SOCK_DGRAM)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "uvnav_tui.cli.main", "live", f"udp://127.0.0.1:{port}",
         "--config", str(cfg), "--out", str(tmp_path / "C.OUT")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path)
    stop = threading.Event()
    sender = threading.Thread(target=send_udp, args=(port, range(30), stop))
    sender.start()
    try:
        sender.join(DEADLINE_S)
        raw = tmp_path / "C.raw.nmea"
        deadline = time.monotonic() + DEADLINE_S
        while not raw.exists() or raw.read_bytes().count(b"\r\n") < 30 * 4:
            assert time.monotonic() < deadline and proc.poll() is None
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=DEADLINE_S)
    finally:
        stop.set()
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, stderr
    assert "interrupted (Ctrl-C)" in stderr
    printed = cycle_lines(stdout)
    cycles = read_out_log(tmp_path / "C.OUT").cycles
    assert len(printed) == len(cycles) == 30  # 29 closed epochs + the open one at the end
    assert "epochs 30  fixes 30" in stdout


def test_live_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = write_config(tmp_path / "boat.toml")
    assert main(["live", "http://x:1", "--config", str(cfg)]) == 2
    assert "uvnav live: source: Unknown source kind" in capsys.readouterr().err
    assert main(["live", "udp://127.0.0.1:99999", "--config", str(cfg)]) == 2
    assert "source port: Port must be a number from 1 to 65535 ! (got '99999')" in \
        capsys.readouterr().err
    assert main(["live", "udp://127.0.0.1:1", "--config", str(tmp_path / "none.toml")]) == 2
    assert "none.toml: File not found !" in capsys.readouterr().err
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as holder:
        holder.bind(("127.0.0.1", 0))
        port = holder.getsockname()[1]
        out = tmp_path / "busy.OUT"
        assert main(["live", f"udp://127.0.0.1:{port}", "--config", str(cfg),
                     "--out", str(out)]) == 2
    assert "Address already in use" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["boat.toml"]  # nothing left behind


def send_lines_udp(port: int, lines: list[str], pace_s: float, stop: threading.Event,
                   per_datagram: int = 4) -> None:
    """``lines``, ``per_datagram`` to a datagram, one datagram every ``pace_s``."""
    if not wait_bound_udp(port, stop):
        return
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
        for i in range(0, len(lines), per_datagram):
            out.sendto("".join(s + "\r\n" for s in lines[i:i + per_datagram]).encode(),
                       ("127.0.0.1", port))
            if stop.wait(pace_s):
                return


def test_live_relative_out_names_a_run_file_that_exists(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """--out relative to the current directory, the configuration elsewhere: the .OUT
    header's run_file is the raw log (found: built from the configuration's directory, a file
    that does not exist)."""
    cfg = write_config((tmp_path / "cfg").mkdir() or tmp_path / "cfg" / "boat.toml")
    work = tmp_path / "work"
    (work / "sub").mkdir(parents=True)
    monkeypatch.chdir(work)
    port = free_port(socket.SOCK_DGRAM)
    status = live_while_sending(send_udp, (port, range(6)),
                                ["live", f"udp://127.0.0.1:{port}", "--config", str(cfg),
                                 "--out", "sub/L.OUT", "--cycles", "4"], 60.0)
    assert status == 0
    head = (work / "sub" / "L.OUT").read_text().splitlines()
    run_file = next(ln for ln in head if ln.startswith("# run_file = "))
    named = Path(run_file.split(" = ", 1)[1].strip('"'))
    assert named == work / "sub" / "L.raw.nmea" and named.exists()


def test_live_one_wild_clock_sentence_does_not_stall_the_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A ZDA dated 2099 in the stream (found: every later sentence skipped as "time went
    backwards" while the state said "receiving"): skipped alone, the cycles go on."""
    cfg = write_config(tmp_path / "boat.toml")
    port = free_port(socket.SOCK_DGRAM)
    lines = [s for k in range(10) for s in epoch_lines(k)]
    lines += [nmea("GPZDA,120009.50,02,12,2099,00,00")]
    lines += [s for k in range(10, 25) for s in epoch_lines(k)]
    status = live_while_sending(
        send_lines_udp, (port, lines, 0.01),
        ["live", f"udp://127.0.0.1:{port}", "--config", str(cfg), "--out",
         str(tmp_path / "W.OUT"), "--cycles", "22", "--seconds", "30"], 60.0)
    out = capsys.readouterr().out
    assert status == 0, out
    assert len(cycle_lines(out)) == 22
    assert "implausible time 1" in out and "CLOCK" not in out


def test_live_clock_stall_is_said(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The stream's clock really goes back (a log restarted 100 s earlier): the run cannot go
    back, its sentences are skipped until it passes the last epoch, and that is said (found:
    silent, the state still "receiving")."""
    cfg = write_config(tmp_path / "boat.toml")
    port = free_port(socket.SOCK_DGRAM)
    lines = [s for k in range(8) for s in epoch_lines(k)]
    lines += [s for k in range(-100, -80) for s in epoch_lines(k)]
    status = live_while_sending(
        send_lines_udp, (port, lines, 0.05),
        ["live", f"udp://127.0.0.1:{port}", "--config", str(cfg), "--out",
         str(tmp_path / "S.OUT"), "--seconds", "2.5"], 60.0)
    out = capsys.readouterr().out
    assert status == 0, out
    said = [ln for ln in out.splitlines() if " CLOCK BEHIND " in ln]
    assert said and "the stream's time went back, its sentences are skipped" in said[0], out
    assert "time went backwards" in out  # the summary's count


def test_live_overload_is_a_message_of_the_next_cycle(tmp_path: Path) -> None:
    """Lines dropped under overload (a small byte bound, a burst nobody polls): the next
    cycle's MSG line in the .OUT says how many, and the state says DROPPED."""
    from engine.api import load_run_config, open_live_run

    cfg, data = load_run_config(write_config(tmp_path / "boat.toml"))
    port = free_port(socket.SOCK_DGRAM)
    run = open_live_run(f"udp://127.0.0.1:{port}", cfg, data, out_path=tmp_path / "O.OUT",
                        queue_bytes=16 * 1024, history=1)
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
            for k in range(300):
                out.sendto("".join(s + "\r\n" for s in epoch_lines(k)).encode(),
                           ("127.0.0.1", port))
        deadline = time.monotonic() + DEADLINE_S
        seen = -1
        # Until the reader has taken what came and has dropped: lines that stop growing for
        # 0.3 s may be a reader thread starved on a loaded machine, not a drained socket.
        while run.feed.source.state.lines != seen or run.feed.source.state.dropped == 0:
            assert time.monotonic() < deadline
            seen = run.feed.source.state.lines
            time.sleep(0.3)
        assert run.state.dropped > 0 and "DROPPED" in run.state.describe()
        while run.cycles < 5:
            assert time.monotonic() < deadline
            run.poll(0.1)
    finally:
        run.close()
    msgs = [t for c in read_out_log(tmp_path / "O.OUT").cycles for tag, f in c.lines
            if tag == "MSG" for t in [str(f["text"])] if t.startswith("Live source overloaded")]
    assert len(msgs) == 1
    assert f"({run.feed.source.state.dropped} lines dropped by UVNAV" in msgs[0]
