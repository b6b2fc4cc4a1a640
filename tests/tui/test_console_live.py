"""The console on a live NMEA source (docs/LIVE.md): the run file is a UDP URL, a sender
thread plays the stream over a real localhost socket, the state line shows the source's state.

Waits are on conditions (tests/tui/test_console_support.wait_for), generous for a loaded
machine. The silence after which the source is lost is shortened to 0.5 s for the test
(run_control.LIVE_LOST_AFTER_S; 5 s in use).
"""

from __future__ import annotations

import socket
import threading
from pathlib import Path

import pytest
from textual.pilot import Pilot

from engine.api import load_config
from engine.io.outlog import read_out_log
from tests.live_helpers import epoch_lines, expected_lat, free_port, wait_bound_udp, write_config
from tests.tui.test_console_support import drive, start, wait_for
from uvnav_tui import run_control
from uvnav_tui.app import UVNAVApp
from uvnav_tui.widgets.state_line import StateLine


def test_console_runs_on_a_udp_source(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(run_control, "LIVE_LOST_AFTER_S", 0.5)
    port = free_port(socket.SOCK_DGRAM)
    url = f"udp://127.0.0.1:{port}"
    cfg = load_config(write_config(tmp_path / "boat.toml", run_file=url))
    app = UVNAVApp(cfg, hardcopy_dir=tmp_path / "hardcopy")
    stop = threading.Event()
    seconds = iter(range(1000))

    def send(n: int) -> None:
        assert wait_bound_udp(port, stop)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
            for _ in range(n):
                k = next(seconds)
                out.sendto("".join(s + "\r\n" for s in epoch_lines(k)).encode(),
                           ("127.0.0.1", port))
                stop.wait(0.01)

    def state_text() -> str:
        return str(app.screen_stack[0].query_one(StateLine).render())

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot)  # Return in Parameter Initialization: the URL is the run file
        control = app.control
        assert control is not None and control.live is not None
        assert control.pace == "live"
        first = threading.Thread(target=send, args=(10,))
        first.start()
        await wait_for(pilot, lambda: control.cycles >= 9, "9 cycles")
        first.join()
        app.refresh_display()
        await wait_for(pilot, lambda: f"LIVE receiving {url}" in state_text(),
                       "the state line to show the live source")
        assert "Pace live" in state_text()
        await wait_for(pilot, lambda: "SOURCE LOST" in state_text(), "SOURCE LOST")
        assert state_text().startswith("Working...")
        # A menu open: the run is Interrupted, but what comes is still received and logged.
        await pilot.press("f10")
        await wait_for(pilot, lambda: control.state == "interrupted", "Interrupted")
        held = control.cycles
        raw = control.live.raw_path
        assert raw is not None
        again = threading.Thread(target=send, args=(5,))
        again.start()
        await wait_for(pilot, lambda: raw.read_bytes().count(b"\r\n") == 15 * 4,
                       "the raw log to get the lines sent while interrupted")
        again.join()
        assert control.cycles == held  # no cycle while a menu is open (THEORY D44)
        await pilot.press("escape")
        await wait_for(pilot, lambda: control.cycles >= 14, "cycles after the menu closed")
        await wait_for(pilot, lambda: "receiving" in state_text(), "receiving again")
        texts = [e.text for e in app.message_log.since(0)[1]]
        assert f"Source receiving from {url}" in texts
        assert any(t.startswith(f"Source lost: {url} (no data for 0.5 s)") for t in texts)
        assert f"Source receiving again from {url}" in texts
        app.stop_run()

    async def guarded(pilot: Pilot[None]) -> None:
        try:
            await script(pilot)
        finally:
            app.stop_run()  # the live worker ends (also when an assertion failed)

    try:
        drive(app, guarded, size=(140, 40))
    finally:
        stop.set()
    assert not any(t.name.startswith("uvnav-live") for t in threading.enumerate())
    outs = sorted(tmp_path.glob("live-*.OUT"))
    assert len(outs) == 1
    cycles = read_out_log(outs[0]).cycles
    assert len(cycles) >= 14
    lats = [c.first("GPS")["lat_in"] for c in cycles]  # type: ignore[index]
    assert lats == pytest.approx([expected_lat(k) for k in range(len(cycles))], abs=1e-9)
    raw = outs[0].with_name(outs[0].name.replace(".OUT", ".raw.nmea"))
    assert raw.read_bytes().count(b"\r\n") == 15 * 4  # every line sent, in the raw log
