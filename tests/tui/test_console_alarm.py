"""What the watch officer must see when a live source is lost (docs/CONSOLE.md, "Live source
lost"): an alarm in reverse video on the state line, never cut at 80×24, a bell until it is
acknowledged with F3, the MPP dead-reckoned on the wall clock with a growing ellipse, and the
age of the last fix. A real UDP source on localhost; the loss after 0.5 s of silence (5 s in
use)."""

from __future__ import annotations

import socket
import threading
from pathlib import Path

import pytest
from textual.pilot import Pilot
from textual.widgets import Static

from engine.api import load_config
from tests.live_helpers import epoch_lines, free_port, wait_bound_udp, write_config
from tests.tui.test_console_support import drive, start, wait_for
from uvnav_tui import run_control
from uvnav_tui.app import UVNAVApp
from uvnav_tui.widgets.state_line import StateLine
from uvnav_tui.widgets.status_column import fix_age_text


def test_fix_age_text() -> None:
    assert fix_age_text(None) == "no fix yet"
    assert fix_age_text(37.9) == "fix 37 s ago"
    assert fix_age_text(12 * 60 + 5) == "fix 12 min ago"
    assert fix_age_text(2 * 3600 + 5 * 60) == "fix 2 h 05 min ago"


def test_source_lost_is_an_alarm(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(run_control, "LIVE_LOST_AFTER_S", 0.5)
    port = free_port(socket.SOCK_DGRAM)
    url = f"udp://127.0.0.1:{port}"
    cfg = load_config(write_config(tmp_path / "boat.toml", run_file=url))
    app = UVNAVApp(cfg, hardcopy_dir=tmp_path / "hardcopy")
    bells: list[int] = []
    monkeypatch.setattr(app, "bell", lambda: bells.append(1))
    stop = threading.Event()

    def send(n: int) -> None:
        assert wait_bound_udp(port, stop)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
            for k in range(n):
                out.sendto("".join(s + "\r\n" for s in epoch_lines(k)).encode(),
                           ("127.0.0.1", port))
                stop.wait(0.01)

    def line() -> StateLine:
        return app.screen_stack[0].query_one(StateLine)

    def mpp_box() -> Static:
        return app.screen_stack[0].query_one("#box-mpp", Static)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot)
        control = app.control
        assert control is not None and control.live is not None
        sender = threading.Thread(target=send, args=(10,))
        sender.start()
        await wait_for(pilot, lambda: control.cycles >= 9, "9 cycles")
        sender.join()
        last = control.latest
        assert last is not None and last.mpp.source == "KF"
        await wait_for(pilot, lambda: "SOURCE LOST" in str(line().render()), "SOURCE LOST")
        text = line().render()
        plain = str(text)
        assert len(plain) == 80 and plain.endswith("Pg 100")
        # the alarm whole, with its key, in reverse video (the rest may be cut)
        start_at = plain.index("SOURCE LOST")
        alarm = plain[start_at:plain.index("F3 ack") + len("F3 ack")]
        spans = [s for s in text.spans if "reverse" in str(s.style)]
        assert spans and spans[0].start <= start_at and spans[0].end >= start_at + len(alarm)
        await wait_for(pilot, lambda: bells, "the bell")
        # dead reckoning on the wall clock: the MPP moves on, its ellipse grows, DR says so
        await wait_for(pilot, lambda: str(mpp_box().border_subtitle).startswith("DR"),
                       "the MPP box to show DR")
        first = control.dead_reckoned()
        await wait_for(pilot, lambda: control.wall_since_cycle_s() > (
            2.5), "2.5 s of silence")
        later = control.dead_reckoned()
        assert first is not None and later is not None
        assert later.mpp.ellipse.scaled(0.95)[0] > first.mpp.ellipse.scaled(0.95)[0]
        assert later.mpp.y_m > first.mpp.y_m > last.mpp.y_m  # heading 0°, 5 kn: north
        assert "fix " in str(mpp_box().border_subtitle)
        assert control.fix_age_s() >= 2.5
        # F3 acknowledges: the bell stops, the alarm stays (steady), logged
        await pilot.press("f3")
        assert control.alarm_acked
        await wait_for(pilot, lambda: "F3 ack" not in str(line().render()), "acknowledged")
        assert "SOURCE LOST" in str(line().render())
        texts = [e.text for e in app.message_log.since(0)[1]]
        assert f"Alarm acknowledged: source lost {url}" in texts
        rung = len(bells)
        assert not control.bell_due()
        assert len(bells) == rung

    async def guarded(pilot: Pilot[None]) -> None:
        try:
            await script(pilot)
        finally:
            app.stop_run()

    try:
        drive(app, guarded, size=(80, 24))
    finally:
        stop.set()
