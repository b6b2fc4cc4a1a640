"""``uvnav script``: the script language, headless runs and the shipped demo tour."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_console_support import DATA, copy_data

from uvnav_tui.cli.script import run_script
from uvnav_tui.menus import find_path
from uvnav_tui.script import ScriptError, parse_script


@pytest.fixture
def data_dir(tmp_path: Path) -> Path:
    """A private copy of the data files."""
    return copy_data(tmp_path / "data")


def test_parse_script() -> None:
    """Comments and blank lines are skipped; ``type`` keeps its spaces."""
    steps = parse_script("# c\n\nmenu Setup > Systems > GPS\ntype 52 50 N  4 30 E\nwait 5\n")
    assert [(s.line_no, s.command, s.arg) for s in steps] == [
        (3, "menu", "Setup > Systems > GPS"), (4, "type", "52 50 N  4 30 E"), (5, "wait", "5")]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("jump 5", "line 1: unknown command 'jump'"),
        ("\nwait soon", "line 2: wait must be a whole number"),
        ("wait", "line 1: wait needs an argument"),
        ("lop maybe", "line 1: lop must be yes, no or ask"),
        ("sleep x", "line 1: sleep needs seconds"),
    ],
)
def test_parse_errors(text: str, message: str) -> None:
    """Bad lines are reported with their line number before anything runs."""
    with pytest.raises(ScriptError) as info:
        parse_script(text)
    assert str(info.value).startswith(message)


def test_demo_script_parses_and_its_menus_exist() -> None:
    """The shipped tour parses and every menu path in it exists for the navigator."""
    steps = parse_script((DATA / "demo.script").read_text(encoding="utf-8"))
    menus = [s.arg for s in steps if s.command == "menu"]
    assert menus
    for path in menus:
        find_path([p.strip() for p in path.split(">")], False)
    assert sum(s.command == "hardcopy" for s in steps) >= 5


def test_headless_script_writes_hardcopies(data_dir: Path, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    """A short tour on the sample: start, GPS off, DR, suspend, end of file, hardcopies."""
    script = tmp_path / "tour.script"
    script.write_text(
        "# sample tour\n"
        "key enter\n"
        "wait 2\n"
        "menu Setup > Systems > GPS\n"
        "key space\n"
        "key enter\n"
        "wait 2\n"
        "hardcopy\n"
        "page 641\n"
        "hardcopy\n"
        "page 100\n"
        "suspend\n"
        "continue\n"
        "wait 50\n"
        "hardcopy\n",
        encoding="utf-8")
    out = tmp_path / "hc"
    status = run_script([str(script), "--headless", "--config", str(data_dir / "920917_1.toml"),
                         "--hardcopy-dir", str(out)])
    assert status == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == [
        "UVNAV_920917_1_083541_Pg100.svg", "UVNAV_920917_1_083541_Pg100.txt",
        "UVNAV_920917_1_083541_Pg641.svg", "UVNAV_920917_1_083541_Pg641.txt",
        "UVNAV_920917_1_083547_Pg100.svg", "UVNAV_920917_1_083547_Pg100.txt"]
    dr = (out / "UVNAV_920917_1_083541_Pg100.txt").read_text(encoding="utf-8")
    assert "Setup ▸ Systems ▸ GPS off" in dr and "│ off" in dr
    end = (out / "UVNAV_920917_1_083547_Pg100.txt").read_text(encoding="utf-8")
    assert "Suspended..." in end and "End of data file" in end
    side = (out / "UVNAV_920917_1_083541_Pg641.txt").read_text(encoding="utf-8")
    assert "Systems: ....D" in side and "Pg 641" in side
    assert "hardcopy" in capsys.readouterr().out
    assert list(data_dir.glob("920917_1*.OUT"))


def test_headless_script_failure(data_dir: Path, tmp_path: Path,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    """A line that cannot run stops the script with its line number and status 1."""
    script = tmp_path / "bad.script"
    script.write_text("key enter\nmenu Setup > Warp drive\n", encoding="utf-8")
    status = run_script([str(script), "--headless", "--config", str(data_dir / "920917_1.toml"),
                         "--hardcopy-dir", str(tmp_path / "hc"), "--no-out"])
    assert status == 1
    assert "line 2: no item 'Warp drive' in Setup" in capsys.readouterr().err


def test_bad_script_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A parse error or a missing file is exit status 2 and no console opens."""
    script = tmp_path / "bad.script"
    script.write_text("frobnicate\n", encoding="utf-8")
    assert run_script([str(script), "--headless"]) == 2
    assert "line 1: unknown command 'frobnicate'" in capsys.readouterr().err
    assert run_script([str(tmp_path / "missing.script"), "--headless"]) == 2
    assert "File not found !" in capsys.readouterr().err


def test_demo_tour_headless(data_dir: Path, tmp_path: Path) -> None:
    """The shipped tour runs end to end on DEMO: DR, fix, dive, predict, resurface, end."""
    out = tmp_path / "hc"
    status = run_script([str(DATA / "demo.script"), "--headless", "--config",
                         str(data_dir / "DEMO.toml"), "--hardcopy-dir", str(out), "--no-out"])
    assert status == 0
    texts = {p.stem: p.read_text(encoding="utf-8") for p in sorted(out.glob("*.txt"))}
    assert list(texts) == [
        "UVNAV_DEMO_100059_Pg100", "UVNAV_DEMO_100459_Pg100", "UVNAV_DEMO_100459_Pg641",
        "UVNAV_DEMO_104959_Pg100", "UVNAV_DEMO_104959_Predict", "UVNAV_DEMO_113459_Pg100",
        "UVNAV_DEMO_113459_Pg100_2", "UVNAV_DEMO_115959_Pg100"]
    assert "Chain 9B  off" in texts["UVNAV_DEMO_100059_Pg100"]
    assert "X 38" in texts["UVNAV_DEMO_100459_Pg100"]  # GPS fix in ECEF
    dive = texts["UVNAV_DEMO_104959_Pg100"]
    assert "Hg : -50" in dive and "no fix" in dive
    assert "Kalman ▸ Predict." in texts["UVNAV_DEMO_104959_Predict"]  # named after the table
    assert "+10:00" in texts["UVNAV_DEMO_104959_Predict"]
    assert "Suspended..." in texts["UVNAV_DEMO_113459_Pg100_2"]
    final = texts["UVNAV_DEMO_115959_Pg100"]
    assert "Suspended..." in final and "End of data file" in final


def test_console_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``uvnav`` finds the bundled demo; a bad configuration is exit status 2, no traceback."""
    from uvnav_tui.cli.console import default_config_path
    from uvnav_tui.cli.main import main

    assert default_config_path() == DATA / "DEMO.toml"
    assert main(["--config", str(tmp_path / "nope.toml")]) == 2
    assert "File not found !" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text('datum = "ED50"\ndepth_m = -3\n', encoding="utf-8")
    assert main(["--config", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "bad.toml:2:" in err and "Wrong depth input !" in err


@pytest.mark.parametrize(("line", "where", "message"), [
    ('datum = "ED51"', "datum", "Unknown datum !"),
    ('[decca]\nchain = "9C"', "decca.chain", "Unknown chain !"),
])
def test_console_and_script_locate_unknown_names(tmp_path: Path, line: str, where: str,
                                                 message: str,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """An unknown datum or chain in the configuration is reported as FILE:LINE: field by the
    console and by ``uvnav script`` (checked against the data files before anything opens)."""
    from uvnav_tui.cli.main import main

    data = copy_data(tmp_path / "data")
    cfg = data / "bad.toml"
    cfg.write_text(f'run_file = "920917_1.RUN"\n{line}\n', encoding="utf-8")
    script = tmp_path / "s.script"
    script.write_text("key enter\n", encoding="utf-8")
    expected_line = 2 if where == "datum" else 3
    for argv in (["--config", str(cfg)], ["script", str(script), "--config", str(cfg),
                                          "--headless"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert f"bad.toml:{expected_line}: {where}: {message}" in err, err


def test_quitting_the_console_ends_a_waiting_script(data_dir: Path) -> None:
    """The operator quits while the script waits for cycles (the demo at real pace: a cycle a
    second, 100000 asked for): the script is given up at once. Textual waits for its script
    before it exits, so the console used to stay on a blank screen for the wait's timeout."""
    import asyncio
    import time

    from test_console_support import drive, make_app, wait_for

    from uvnav_tui.script import ScriptRunner

    app = make_app(data_dir, "DEMO", pace_override=None)
    outcome: list[object] = []

    async def script(pilot) -> None:  # type: ignore[no-untyped-def]
        runner = ScriptRunner(pilot, headless=True)
        work = asyncio.ensure_future(
            runner.run_or_quit(parse_script("key enter\nwait 100000\n")))
        await wait_for(pilot, lambda: app.control is not None and app.control.cycles >= 1,
                       "the first cycle")
        t0 = time.monotonic()
        app.exit()
        outcome.append(await asyncio.wait_for(work, 30.0))
        outcome.append(time.monotonic() - t0)

    drive(app, script)
    assert outcome[0] is False
    assert outcome[1] < 30.0
