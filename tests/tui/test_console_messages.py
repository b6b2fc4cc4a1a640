"""Messages as a watch officer needs them (docs/CONSOLE.md, "The message log"): sorted into
alarm, warning and information, repeats grouped (``×30 in 8 min``), each saying what to do,
and the start and end of each run marked, in the Pg 100 panel and in F2."""

from __future__ import annotations

from datetime import timedelta
from pathlib import Path

from textual.pilot import Pilot

from tests.tui.test_console_support import drive, make_app, start, text_of, wait_for
from uvnav_tui.screens.message_screen import MessageScreen
from uvnav_tui.widgets.message_line import MessageLine
from uvnav_tui.widgets.message_log import ALARM, INFO, WARNING, MessageLog, classify
from uvnav_tui.widgets.message_panel import MessagePanel, group_texts

INNOVATION = ("Fix fails the innovation test: T = {t:.2f} > 1.94, worst lse_x w = +3.1 "
              "(taken; check it)")


def test_the_demo_messages_are_sorted_and_say_what_to_do() -> None:
    """The three messages a two-hour demo repeats 150 times each (issue: no hint of what to
    check) are warnings or information, with advice naming the page to look at."""
    level, _, advice = classify(INNOVATION.format(t=3.2))
    assert level == WARNING and "Pg 641" in advice and "Pg 650" in advice
    level, _, advice = classify("unit variance rejected: S² = 4.120 outside (0.0506, 2.996)")
    assert level == WARNING and "Pg 633" in advice
    level, _, advice = classify("advice: scale the a priori VCV by S²")
    assert level == INFO and "Demo ▸ LS params" in advice
    assert classify("Source lost: udp://127.0.0.1:10110 (no data for 5 s)")[0] == ALARM
    # not listed: information, grouped with those differing only in numbers
    assert classify("CM changed to +3°: grid re-projected")[:2] == (
        INFO, classify("CM changed to +9°: grid re-projected")[1])


def test_repeats_group_within_ten_minutes() -> None:
    from datetime import UTC, datetime

    log = MessageLog()
    t0 = datetime(2026, 1, 1, 10, tzinfo=UTC)
    for i in range(40):  # one every 16 s, as in the demo
        log.add(INNOVATION.format(t=3 + i % 3), t0 + timedelta(seconds=16 * i), "engine")
    groups = log.recent_groups(10)
    assert [g.count for g in groups] == [38, 2]  # 37 × 16 s = 592 s ≤ 10 min
    assert groups[0].repeat_text() == "×38 in 10 min, last 10:09:52Z"
    assert groups[0].line().startswith("10:00:00Z WARN  Fix fails the innovation test")
    assert groups[1].repeat_text() == "×2 in 1 min, last 10:10:24Z"
    alarm = classify("Source lost: x")
    log.add("Source lost: x (no data for 5 s)", t0, "data")
    texts = group_texts(log.recent_groups(1)[0], advice=True)
    assert alarm[0] == ALARM and "reverse" in str(texts[0].style)
    assert texts[1].plain.strip().startswith("⤷ the MPP is dead-reckoned")


def test_panel_and_f2_show_groups_advice_and_run_marks(data_dir: Path) -> None:
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        r = app.control.latest
        for i in range(30):
            when = r.time + timedelta(seconds=16 * i)
            app.message_log.add(INNOVATION.format(t=3.0 + i / 100), when, "engine")
            app.message_log.add("advice: scale the a priori VCV by S²", when, "engine")
        app.refresh_display()
        await pilot.pause()
        panel = app.screen.query_one(MessagePanel)
        assert panel.display
        shown = text_of(app)
        assert "──── Run started: 920917_1.RUN ────" in shown
        assert shown.count("Fix fails the innovation test") == 1
        assert "WARN  Fix fails the innovation test: T = 3.29" in shown
        assert "×30 in 8 min" in shown
        assert "⤷ the fix was used: compare the LSE and the MPP (Pg 641)" in shown
        # information has no advice line in the panel, but does in F2
        assert "⤷ the fix's VCV is scaled by S²" not in shown
        await pilot.press("f2")
        await wait_for(pilot, lambda: isinstance(app.screen, MessageScreen), "F2")
        await pilot.pause()
        log_text = text_of(app)
        assert "──── Run started: 920917_1.RUN (20" in log_text and "×30 in 8 min" in log_text
        assert "⤷ the fix's VCV is scaled by S²" in log_text
        # what to do wraps under itself (hanging indent), not back to the frame's edge, once
        # the log screen is laid out

        def hanging() -> bool:
            lines = text_of(app).splitlines()
            at = next(i for i, ln in enumerate(lines) if "⤷ the fix was used" in ln)
            return lines[at + 1].startswith("│" + " " * 12) and lines[at + 1][13] != " "

        await wait_for(pilot, hanging, "the advice wrapped with a hanging indent", 10.0)
        # W: only alarms and warnings (the run marks stay); A: everything again
        await pilot.press("w")
        await wait_for(pilot, lambda: "advice: scale" not in text_of(app), "W filter")
        assert "WARN  Fix fails the innovation test" in text_of(app)
        assert "──── Run started" in text_of(app)
        await pilot.press("a")
        await wait_for(pilot, lambda: "advice: scale" in text_of(app), "A: all")
        await pilot.press("escape")
        # an alarm on the message line is in reverse video
        app.message_log.add("Source lost: udp://127.0.0.1:1 (no data for 5 s)", r.time, "data")
        app.refresh_display()
        await pilot.pause()
        line = app.screen.query_one(MessageLine)
        assert "Source lost" in line.text and "reverse" in str(line.render().spans)
        app.stop_run()
        marks = [g.line() for g in app.message_log.recent_groups(100) if g.is_mark]
        assert marks[0].startswith("──── Run started") and marks[-1].startswith(
            "──── Run ended: ") and " cycles, last record 08:35:" in marks[-1]

    drive(app, script, size=(160, 50))
