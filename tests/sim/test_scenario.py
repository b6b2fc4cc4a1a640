"""Scenario files: defaults, the bundled demo, located errors, and the ``uvnav simulate`` CLI."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import pytest

from engine.errors import InputError
from engine.io.operator_input import parse_position
from engine.sim.scenario import (
    Current,
    GpsModel,
    SensorSet,
    load_scenario,
    parse_scenario_text,
)
from engine.sim.simulate import read_data_files
from tests.paths import DATA
from uvnav_tui.cli.simulate import run_simulate

DEMO = DATA / "DEMO.scenario.toml"

HEAD = 'start_time = "1992-09-17T08:00:00Z"\nstart_position = "52 50 00 N 004 30 00 E"\n'
LEG = "[[leg]]\nduration_s = 60\ncourse_deg = 232\nspeed_kn = 10\n"
MINIMAL = HEAD + LEG


@pytest.fixture(scope="module")
def data_files():
    return read_data_files(DATA)


def test_minimal_scenario_takes_the_documented_defaults() -> None:
    sc = parse_scenario_text(MINIMAL, "min.toml")
    assert sc.start_time == datetime(1992, 9, 17, 8, 0, 0, tzinfo=UTC)
    assert (sc.start_lat_deg, sc.start_lon_deg) == parse_position("52 50 00 N 004 30 00 E")
    assert (sc.datum, sc.run_gps_datum, sc.sample_interval_s) == ("ED50", "WGS84", 1)
    # SA-era GPS (THEORY §3.1, §11.1–11.2), thesis sensor σ (THEORY §3.7–3.8).
    assert sc.gps == GpsModel(on=True, sigma_m=35.0, tau_s=240.0, white_sigma_m=5.0)
    assert sc.gyro.sigma_deg == 0.65 and sc.log.sigma_frac == 0.02
    assert sc.pressure.sigma_m == 1.45 and sc.inclinometer.sigma_deg == 0.5
    assert (sc.echosounder.sigma_a_m, sc.echosounder.sigma_b) == (0.25, 0.0045)
    assert (sc.decca.chain, sc.decca.cf) == ("9B", 64.0)
    assert sc.sensors == SensorSet()  # the thesis sample's sensors: gyro, log, rudder
    leg = sc.legs[0]
    assert (leg.depth_m, leg.surfaced, leg.turn_rate_deg_s) == (0.0, True, 0.5)
    assert leg.current == Current(0.0, 0.0)
    assert (sc.duration_s, sc.n_records) == (60, 60)
    assert sc.end_time == datetime(1992, 9, 17, 8, 0, 59, tzinfo=UTC)


def test_current_override_and_toml_datetime() -> None:
    text = (
        "start_time = 1992-09-17T08:00:00Z\n"  # a TOML offset date-time, not a string
        'start_position = "52 50 N 4 30 E"\n'
        "[current]\nset_deg = 360\nspeed_kn = 0.5\n"
        + LEG
        + "[[leg]]\nduration_s = 30\ncourse_deg = 90\nspeed_kn = 5\ncurrent_set_deg = 200\n"
    )
    sc = parse_scenario_text(text)
    assert sc.start_time == datetime(1992, 9, 17, 8, tzinfo=UTC)
    assert sc.current == Current(0.0, 0.5)  # 360 stored as 0
    assert sc.legs[0].current == Current(0.0, 0.5)
    assert sc.legs[1].current == Current(200.0, 0.5)  # speed from the scenario-wide current
    e, n = Current(90.0, 1.0).east_north_ms()
    assert (e, n) == pytest.approx((1852 / 3600, 0.0), abs=1e-15)


def test_demo_scenario_loads_and_is_the_documented_mission(data_files) -> None:
    datums, chains = data_files
    sc = load_scenario(DEMO, known_datums=datums.datums, known_chains=chains)
    assert sc.duration_s == 7200 and sc.sample_interval_s == 1
    assert sc.datum == "ED50" and sc.run_gps_datum == "WGS84"
    surfaced = [leg.duration_s for leg in sc.legs if leg.surfaced]
    dived = [leg for leg in sc.legs if not leg.surfaced]
    assert sum(surfaced) == 2700 + 1800 and sum(leg.duration_s for leg in dived) == 2700
    assert all(leg.depth_m == 50.0 for leg in dived)
    assert sc.current.speed_kn == 0.5
    assert sc.sensors.pressure and sc.sensors.inclinometer
    assert sc.data_dir == DATA.resolve()
    assert "--seed 1993" in DEMO.read_text(encoding="utf-8")


def test_without_errors_zeroes_every_error_term() -> None:
    sc = parse_scenario_text(MINIMAL).without_errors()
    assert (sc.gps.sigma_m, sc.gps.white_sigma_m) == (0.0, 0.0)
    assert (sc.decca.sigma_scale, sc.decca.white_sigma_lanes) == (0.0, 0.0)
    assert (sc.gyro.bias_deg, sc.gyro.sigma_deg, sc.gyro.gm_sigma_deg) == (0.0, 0.0, 0.0)
    assert (sc.log.scale_factor, sc.log.bias_kn, sc.log.sigma_frac) == (0.0, 0.0, 0.0)
    assert (sc.pressure.bias_m, sc.pressure.sigma_m) == (0.0, 0.0)
    assert (sc.echosounder.sigma_a_m, sc.echosounder.sigma_b) == (0.0, 0.0)


# Each bad text with the exact message (file:line: field: message (got 'text')).
BAD = [
    (HEAD + "colour = 1\n" + LEG, "bad.toml:3: colour: Unknown key ! (got 'colour')"),
    (HEAD + "[wind]\nspeed_kn = 3\n" + LEG, "bad.toml:3: wind: Unknown table ! (got 'wind')"),
    (
        MINIMAL + "[[leg]]\nduration_s = 60\ncourse_deg = 90\nspeed = 5\n",
        "bad.toml:10: leg[2].speed: Unknown key ! (got 'speed')",
    ),
    (
        HEAD + "[[leg]]\nduration_s = 60\ncourse_deg = 232\nspeed_kn = 99\n",
        "bad.toml:6: leg[1].speed_kn: Out of range: must be 0 <= value <= 60 ! (got '99')",
    ),
    (
        HEAD + '[[leg]]\nduration_s = 60\ncourse_deg = 232\nspeed_kn = "ten"\n',
        "bad.toml:6: leg[1].speed_kn: Wrong type: number expected ! (got 'ten')",
    ),
    (
        HEAD + "[[leg]]\nduration_s = 60\ncourse_deg = 232\nspeed_kn = true\n",
        "bad.toml:6: leg[1].speed_kn: Wrong type: number expected ! (got 'true')",
    ),
    (
        MINIMAL + "[[leg]]\nduration_s = 60\nspeed_kn = 5\n",
        "bad.toml:7: leg[2].course_deg: Missing key !",
    ),
    (
        'start_time = "1992-09-17T08:00:00Z"\nstart_position = "52 50 00 X 004 30 00 E"\n' + LEG,
        "bad.toml:2: start_position: Wrong position input format ! "
        "(got '52 50 00 X 004 30 00 E')",
    ),
    (
        'start_time = "1992-09-17T08:00:00+02:00"\nstart_position = "52 50 N 4 30 E"\n' + LEG,
        "bad.toml:1: start_time: Time must be UTC (end with Z or +00:00) ! "
        "(got '1992-09-17T08:00:00+02:00')",
    ),
    (
        'start_time = "1992-09-17T08:00:00"\nstart_position = "52 50 N 4 30 E"\n' + LEG,
        "bad.toml:1: start_time: Time must be UTC (end with Z or +00:00) ! "
        "(got '1992-09-17T08:00:00')",
    ),
    (
        'start_time = "17/09/1992 08:00"\nstart_position = "52 50 N 4 30 E"\n' + LEG,
        "bad.toml:1: start_time: Wrong time: ISO 8601 UTC expected (e.g. 1992-09-17T08:35:38Z) ! "
        "(got '17/09/1992 08:00')",
    ),
    (
        'start_time = "2070-01-01T00:00:00Z"\nstart_position = "52 50 N 4 30 E"\n' + LEG,
        "bad.toml:1: start_time: Year must be 1970-2069 (.RUN dates are YYMMDD) ! "
        "(got '2070-01-01T00:00:00Z')",
    ),
    (
        HEAD + "[gps]\ntau_s = 0\n" + LEG,
        "bad.toml:4: gps.tau_s: Out of range: must be 0 < value ! (got '0')",
    ),
    (
        HEAD + "[gyro]\nsigma_deg = nan\n" + LEG,
        "bad.toml:4: gyro.sigma_deg: Not a finite number ! (got 'nan')",
    ),
    (
        HEAD + "sample_interval_s = 1.5\n" + LEG,
        "bad.toml:3: sample_interval_s: Wrong type: integer expected ! (got '1.5')",
    ),
    (
        HEAD + "sample_interval_s = 2\n[[leg]]\nduration_s = 61\ncourse_deg = 0\nspeed_kn = 5\n",
        "bad.toml:5: leg[1].duration_s: Must be a whole multiple of sample_interval_s ! "
        "(got '61')",
    ),
    (
        HEAD + "water_depth_m = 40\n" + LEG + "depth_m = 50\nsurfaced = false\n",
        "bad.toml:8: leg[1].depth_m: Must be shallower than water_depth_m ! (got '50')",
    ),
    (
        HEAD + LEG + "depth_m = 20\nsurfaced = true\n",
        "bad.toml:8: leg[1].surfaced: A surfaced leg needs depth_m <= fix_depth_max_m ! "
        "(got 'true')",
    ),
    (
        HEAD + "[sensors]\nechosounder = true\n" + LEG,
        "bad.toml:4: sensors.echosounder: The echo sounder needs water_depth_m ! (got 'true')",
    ),
    (
        HEAD + "[current]\nset_deg = 400\n" + LEG,
        "bad.toml:4: current.set_deg: Out of range: must be 0 <= value <= 360 ! (got '400')",
    ),
    (HEAD + "gps = 3\n" + LEG, "bad.toml:3: gps: Wrong type: table expected ! (got '3')"),
    (
        HEAD + "[leg]\nduration_s = 60\ncourse_deg = 0\nspeed_kn = 5\n",
        "bad.toml:3: leg: Wrong type: array of tables [[leg]] expected !",
    ),
    (HEAD, "bad.toml: leg: No [[leg]] table: a scenario needs at least one leg !"),
    (LEG, "bad.toml: start_time: Missing key !"),
]


@pytest.mark.parametrize(("text", "message"), BAD)
def test_bad_scenarios_give_located_messages(text: str, message: str) -> None:
    with pytest.raises(InputError) as info:
        parse_scenario_text(text, "bad.toml")
    assert str(info.value) == message


def test_unknown_datum_and_chain_against_the_data_files(data_files) -> None:
    datums, chains = data_files
    kw = {"known_datums": datums.datums, "known_chains": chains}
    with pytest.raises(InputError) as info:
        parse_scenario_text(HEAD + 'datum = "ED51"\n' + LEG, "bad.toml", **kw)
    assert str(info.value) == "bad.toml:3: datum: Unknown datum ! (got 'ED51')"
    with pytest.raises(InputError) as info:
        parse_scenario_text(HEAD + '[decca]\nchain = "5C"\n' + LEG, "bad.toml", **kw)
    assert str(info.value) == "bad.toml:4: decca.chain: Unknown Decca chain ! (got '5C')"
    sc = parse_scenario_text(HEAD + 'run_gps_datum = "ed50  [dma]"\n' + LEG, **kw)
    assert sc.run_gps_datum == "ED50 [DMA]"  # the file's spelling


def test_toml_syntax_error_is_located() -> None:
    with pytest.raises(InputError) as info:
        parse_scenario_text(HEAD + "speed_kn = = 3\n" + LEG, "bad.toml")
    err = info.value
    assert (err.file, err.line) == ("bad.toml", 3)
    assert err.message.startswith("TOML syntax error: ")


def test_missing_scenario_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="File not found"):
        load_scenario(tmp_path / "nope.toml")


# --------------------------------------------------------------------------------------------
# CLI


def test_cli_bad_scenario_exits_2_with_the_message(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(HEAD + "[[leg]]\nduration_s = 60\ncourse_deg = 232\nspeed_kn = 99\n")
    out = tmp_path / "X.RUN"
    assert run_simulate([str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert (
        f"{bad}:6: leg[1].speed_kn: Out of range: must be 0 <= value <= 60 ! (got '99')" in err
    )
    assert "Traceback" not in err
    assert not out.exists()


def test_cli_writes_refuses_to_overwrite_and_forces(tmp_path: Path, capsys) -> None:
    scen = tmp_path / "short.toml"
    scen.write_text(f'data_dir = "{DATA.as_posix()}"\n' + MINIMAL, encoding="utf-8")
    out = tmp_path / "SHORT.RUN"
    truth = tmp_path / "SHORT.truth.csv"
    assert run_simulate([str(scen), "--out", str(out), "--seed", "5"]) == 0
    assert "wrote 60 records" in capsys.readouterr().out
    first = out.read_bytes()
    assert len(first.splitlines()) == 60 and truth.is_file()  # default truth name
    # Refuse: exit 2, message names the file, nothing touched.
    assert run_simulate([str(scen), "--out", str(out), "--seed", "6"]) == 2
    err = capsys.readouterr().err
    assert f"{out}: --out: File exists (use --force to replace an earlier output) !" in err
    assert out.read_bytes() == first
    # --force replaces it (a different seed gives a different file).
    assert run_simulate([str(scen), "--out", str(out), "--seed", "6", "--force"]) == 0
    assert out.read_bytes() != first


def test_cli_argument_errors_exit_2(tmp_path: Path, capsys) -> None:
    scen = tmp_path / "short.toml"
    scen.write_text(MINIMAL, encoding="utf-8")
    assert run_simulate([str(scen)]) == 2  # --out missing (argparse)
    assert "--out" in capsys.readouterr().err
    assert run_simulate([str(scen), "--out", str(tmp_path / "A.RUN"), "--seed", "-1"]) == 2
    assert "--seed: Must be a whole number >= 0 !" in capsys.readouterr().err
    # data_dir "." next to the scenario holds no TO_WGS84.DAT: a located input error, exit 2.
    assert run_simulate([str(scen), "--out", str(tmp_path / "A.RUN")]) == 2
    assert "TO_WGS84.DAT: File not found !" in capsys.readouterr().err
    assert run_simulate([str(tmp_path / "none.toml"), "--out", str(tmp_path / "A.RUN")]) == 2
    assert "none.toml: File not found !" in capsys.readouterr().err
