"""Run configuration: the sample file, A8.2 defaults, TOML round trip and located errors."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.errors import InputError
from engine.io.formatting import format_dms_input
from engine.run.config import (
    FilterConfig,
    RunConfig,
    all_keys,
    default_config,
    dump_config,
    load_config,
    parse_config_text,
)
from tests.paths import ROOT

SAMPLE = ROOT / "data" / "920917_1.toml"
DATUMS = ["ED50", "ED50 [DMA]", "ED50 [UKOOA]", "NAD 1927", "WGS84"]


def test_sample_configuration_is_the_thesis_start_up() -> None:
    cfg = load_config(SAMPLE)
    # THEORY §12.12 / thesis L5526–5531.
    assert cfg.datum == "ED50"
    assert (cfg.dr_lat_deg, cfg.dr_lon_deg) == pytest.approx((52 + 50 / 60, 4.5), abs=1e-12)
    assert (cfg.depth_m, cfg.current_set_deg, cfg.current_speed_kn) == (0.0, 0.0, 0.0)
    assert cfg.gps.on and cfg.gps.receiver == "C/A" and not cfg.gps.p_code
    assert cfg.decca.on and cfg.decca.chain == "9B"
    assert (cfg.decca.red, cfg.decca.green, cfg.decca.purple) == ("B20", "F34", "A51")
    assert cfg.decca.zone_lane("green") == (5, 34)
    assert cfg.decca.select == ("red", "green")  # Purple entered but not selected
    assert cfg.run_gps_datum == "ED50"
    c = cfg.corrections
    assert (c.decca_red_lanes, c.decca_green_lanes, c.decca_purple_lanes) == (-0.05,) * 3
    assert (c.gps_north_m, c.gps_east_m) == (0.0, 0.0)
    assert cfg.run_path == ROOT / "data" / "920917_1.RUN"
    assert cfg.run_path.is_file()
    assert (cfg.data_dir / "TO_WGS84.DAT").is_file()
    assert (cfg.data_dir / "DECCA.CHN").is_file()


def test_omitted_keys_take_the_a82_defaults() -> None:
    cfg = parse_config_text("")
    # Not A8.2's fixed 64 (summer's day, L8763): the thesis' four conditions by the sun
    # (L8352); the thesis preset keeps 64 (test_thesis_preset_keeps_summer_day_decca_cf)
    assert cfg.lsq.decca_cf == "auto"
    assert cfg.lsq.reliab_interval_pct == 5.0  # ReliabInterval (L8781)
    assert cfg.lsq.conf_region_pct == 95.0  # ConfRegion (L8782)
    assert cfg.lsq.lop_reject == "A"  # LOPReject (L8776)
    assert cfg.lsq.epsilon_m == 1.0 and cfg.lsq.s02 == 1.0
    # Not A8.2's 1 (kept in 920917_1.toml): the SPS specification's 100 m horizontal at 95 %
    # read as a circular normal's 95 % radius, σ = 100/√(−2 ln 0.05) = 40.9 m per axis.
    assert cfg.lsq.gps_se_sf == 0.67
    assert cfg.lsq.scale_vcv is False
    assert cfg.demo.delta_t_s == 1  # DeltaT (L8788)
    assert cfg.demo.s_weight == 1.026  # s_weight (L8768)
    assert cfg.gps.receiver == "C/A"  # PCode = false (L8758)
    assert (cfg.gps.status, cfg.decca.status) == (0, 0)  # Systems[1], Systems[5] (L8712–8716)
    sensors = ("gyro", "log", "rudder", "inclinometer", "pressure", "echosounder")
    assert [cfg.sensors.status(s) for s in sensors] == [1, 1, 0, 2, 0, 2]  # L8718–8723
    assert cfg.filter.on is True  # Filtering ON (L7641)
    assert cfg.filter.q_mode == "vanloan"  # step-size invariant Q (THEORY D24)
    assert cfg.datum == "ED50" and cfg.run_gps_datum == "WGS84"
    assert cfg == default_config()


def test_select_defaults_to_every_entered_pattern() -> None:
    cfg = parse_config_text('[decca]\npurple = "a51"\nred = "b 20"\n')
    assert cfg.decca.select == ("red", "purple")
    assert (cfg.decca.red, cfg.decca.purple) == ("B20", "A51")
    cfg = parse_config_text('[decca]\nred = "B20"\ngreen = "F34"\nselect = ["GREEN", "red"]\n')
    assert cfg.decca.select == ("red", "green")


def test_normalisation_and_known_datums() -> None:
    text = 'datum = "ed50 [dma]"\ncurrent_set_deg = 360\n[lsq]\nlop_reject = "y"\nepsilon_m = 2\n'
    cfg = parse_config_text(text, known_datums=DATUMS)
    assert cfg.datum == "ED50 [DMA]"
    assert cfg.current_set_deg == 0.0
    assert cfg.lsq.lop_reject == "Y"
    assert cfg.lsq.epsilon_m == 2.0 and isinstance(cfg.lsq.epsilon_m, float)
    assert parse_config_text('[demo]\npace = "X10"\n').demo.pace_factor == 10.0


def test_sample_dump_parse_round_trip() -> None:
    cfg = load_config(SAMPLE)
    again = parse_config_text(dump_config(cfg), base_dir=SAMPLE.parent)
    assert again == cfg
    assert dump_config(again) == dump_config(cfg)


def test_replace_is_validated() -> None:
    cfg = default_config()
    moved = cfg.replace(dr_position=format_dms_input(-33.875, 151.21))
    assert (moved.dr_lat_deg, moved.dr_lon_deg) == pytest.approx((-33.875, 151.21), abs=1e-9)
    with pytest.raises(InputError) as caught:
        cfg.replace(dr_position="52 50 N")
    assert (caught.value.message, caught.value.field) == (
        "Wrong position input format !",
        "dr_position",
    )
    with pytest.raises(InputError) as caught:
        dataclasses.replace(cfg.lsq, decca_cf=0.0)
    assert caught.value.field == "lsq.decca_cf"


def test_missing_file() -> None:
    with pytest.raises(InputError) as caught:
        load_config(ROOT / "data" / "no_such_run.toml")
    assert caught.value.message == "File not found !"


# (text, line, field, message or None = any message)
MALFORMED = [
    (
        'datum = "ED50"\n[lsq]\nlop_reject = "Q"\n',
        3,
        "lsq.lop_reject",
        'Must be one of "A", "Y", "N" !',
    ),
    ('[lsq]\nlop_rejet = "Y"\n', 2, "lsq.lop_rejet", "Unknown key !"),
    ("depth_m = 0.0\n\n[lssq]\nepsilon_m = 1.0\n", 3, "lssq", "Unknown table !"),
    ('datumm = "ED50"\n', 1, "datumm", "Unknown key !"),
    (
        "[lsq]\nepsilon_m = 1.0\nreliab_interval = 50\n",
        3,
        "lsq.reliab_interval",
        "Out of range: must be 0 < value < 50 !",
    ),
    (
        "[lsq]\nconf_region = 100.0\n",
        2,
        "lsq.conf_region",
        "Out of range: must be 0 < value < 100 !",
    ),
    ("[lsq]\ndecca_cf = 0\n", 2, "lsq.decca_cf", "Out of range: must be 0 < value !"),
    ("[lsq]\nepsilon_m = -1.0\n", 2, "lsq.epsilon_m", "Out of range: must be 0 < value !"),
    ("[demo]\ndelta_t_s = 1.5\n", 2, "demo.delta_t_s", "Wrong type: a whole number expected !"),
    ("[demo]\ndelta_t_s = 0\n", 2, "demo.delta_t_s", "Out of range: must be 1 <= value <= 3600 !"),
    ('[sensors]\ngyro = "yes"\n', 2, "sensors.gyro", 'Must be one of "on", "off", "n/a" !'),
    ('[gps]\non = "true"\n', 2, "gps.on", "Wrong type: true or false expected !"),
    ('# start-up\ndr_position = "52 50 00 N"\n', 2, "dr_position", "Wrong position input format !"),
    ('[decca]\nchain = "9B"\nred = "B24"\n', 3, "decca.red", "Wrong zone/lane input !"),
    (
        '[decca]\nred = "B20"\nselect = ["red", "purple"]\n',
        3,
        "decca.select",
        "No zone/lane entered for this pattern !",
    ),
    (
        '[decca]\nred = "B20"\nselect = ["red", "blue"]\n',
        3,
        "decca.select",
        "Unknown Decca pattern !",
    ),
    ("depth_m = 1500.0\n", 1, "depth_m", "Wrong depth input !"),
    ('current_speed_kn = "2"\n', 1, "current_speed_kn", "Wrong type: a number expected !"),
    ('[filter]\nmodel = "colored"\n', 2, "filter.model", 'Must be one of "thesis", "coloured" !'),
    ('[filter]\nq_mode = "exact"\n', 2, "filter.q_mode",
     'Must be one of "vanloan", "thesis", "psd" !'),
    ("lsq = 3\n", 1, "lsq", "Wrong type: a table expected !"),
    ('datum = "ED50"\ndepth_m = \n', 2, "depth_m", None),  # TOML syntax error
    ('datum = "ED50"\n[gps\non = true\n', 2, None, None),  # TOML syntax error in a header
]


@pytest.mark.parametrize(("text", "line", "field", "message"), MALFORMED)
def test_malformed_config(text: str, line: int, field: str | None, message: str | None) -> None:
    with pytest.raises(InputError) as caught:
        parse_config_text(text, filename="bad.toml")
    err = caught.value
    assert err.file == "bad.toml"
    assert err.line == line
    assert err.field == field
    if message is not None:
        assert err.message == message
    else:
        assert err.message.startswith("TOML syntax error")
    assert err.text is not None and err.text in text


def test_offending_text_is_the_source_value() -> None:
    with pytest.raises(InputError) as caught:
        parse_config_text('[lsq]\nlop_reject = "Q"   # typo\n')
    assert caught.value.text == '"Q"'


def test_unknown_datum_is_located() -> None:
    with pytest.raises(InputError) as caught:
        parse_config_text('depth_m = 0.0\ndatum = "ED51"\n', "x.toml", known_datums=DATUMS)
    err = caught.value
    assert (err.message, err.field, err.line) == ("Unknown datum !", "datum", 2)


def test_every_key_is_documented() -> None:
    doc = (ROOT / "docs" / "CONFIG.md").read_text(encoding="utf-8")
    for name, _key, _default in all_keys():
        table, _, key = name.rpartition(".")
        assert f"`{key}`" in doc, name
        if table:
            assert f"[{table}]" in doc, table


_finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False)
_positive = st.floats(min_value=1e-6, max_value=1e6, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    lat=st.floats(min_value=-90, max_value=90),
    lon=st.floats(min_value=-180, max_value=180),
    depth=st.floats(min_value=0, max_value=1000),
    chain=st.text(min_size=1, max_size=12).filter(lambda s: s.strip() == s and s != ""),
    run_file=st.text(min_size=1, max_size=12).filter(
        lambda s: s.strip() == s and s != "" and "\x00" not in s
    ),
    reject=st.sampled_from(["A", "Y", "N"]),
    delta_t=st.integers(min_value=1, max_value=3600),
    correction=_finite,
    cf=_positive,
    gps_on=st.booleans(),
    pace=st.sampled_from(["real", "fast", "x10", "x0.5"]),
)
def test_dump_parse_round_trip_hypothesis(
    lat: float,
    lon: float,
    depth: float,
    chain: str,
    run_file: str,
    reject: str,
    delta_t: int,
    correction: float,
    cf: float,
    gps_on: bool,
    pace: str,
) -> None:
    base = default_config()
    cfg = base.replace(
        dr_position=format_dms_input(lat, lon),
        depth_m=depth,
        run_file=run_file,
        gps=dataclasses.replace(base.gps, on=gps_on),
        decca=dataclasses.replace(base.decca, chain=chain, red="B20", select=("red",)),
        corrections=dataclasses.replace(base.corrections, decca_green_lanes=correction),
        lsq=dataclasses.replace(base.lsq, lop_reject=reject, decca_cf=cf),
        demo=dataclasses.replace(base.demo, delta_t_s=delta_t, pace=pace),
    )
    again = parse_config_text(dump_config(cfg), base_dir=Path(os.curdir))
    assert again == cfg


def test_runconfig_is_frozen() -> None:
    cfg = RunConfig()
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.datum = "WGS84"  # type: ignore[misc]


_TOML_ALPHABET = st.sampled_from(
    list("[]{}=,.\"'#\n abc_lsqdemogpsredon0123456789-+eE") + ["lsq", "decca", "select"]
)


@settings(max_examples=300, deadline=None)
@given(st.one_of(st.text(max_size=60), st.lists(_TOML_ALPHABET, max_size=30).map("".join)))
def test_arbitrary_text_raises_only_input_error(text: str) -> None:
    try:
        cfg = parse_config_text(text, "fuzz.toml")
    except InputError as err:
        assert err.file == "fuzz.toml" and err.message
        assert err.line is None or 1 <= err.line <= max(1, len(text.splitlines()))
    else:
        assert isinstance(cfg, RunConfig)


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("[[lsq]]\nepsilon_m = 1\n", "lsq"),
        ("[lsq.extra]\nx = 1\n", "lsq.extra"),
        ("datum = 1979-05-27\n", "datum"),
        ('[decca]\nred = "B20"\nselect = [1]\n', "decca.select"),
        ("depth_m = inf\n", "depth_m"),
        ('[demo]\npace = "x0"\n', "demo.pace"),
    ],
)
def test_odd_toml_values_are_input_errors(text: str, field: str) -> None:
    with pytest.raises(InputError) as caught:
        parse_config_text(text)
    assert caught.value.field == field
    assert caught.value.line is not None


def test_filter_keys_reach_the_filter_parameters() -> None:
    """q_mode and the A11 bias random walks go from the TOML to engine.filter.kalman: with
    gyro_bias_rw_deg_sqrth = 0.7 the gyro-bias PSD is (0.7°)²/3600 s per s (rad²/s), and the
    biases have no noise at all unless bias_noise is on (the thesis' random constants)."""
    import math

    import numpy as np

    from engine.filter.kalman import process_noise
    from engine.run.cycle import filter_params_from_config

    off = filter_params_from_config(parse_config_text('[filter]\npreset = "thesis"\n'))
    assert off.q_mode == "vanloan" and not off.bias_noise
    assert np.all(np.diag(process_noise(off, 1.0))[5:] == 0.0)
    cfg = parse_config_text('[filter]\nq_mode = "THESIS"\nbias_noise = true\n'
                            "gyro_bias_rw_deg_sqrth = 0.7\nlog_bias_rw_ms_sqrth = 0.02\n")
    p = filter_params_from_config(cfg)
    assert p.q_mode == "thesis" and p.bias_noise
    q = np.diag(process_noise(p, 1.0))
    assert q[6] == pytest.approx(math.radians(0.7) ** 2 / 3600.0, rel=1e-12)
    assert q[5] == pytest.approx(0.02**2 / 3600.0, rel=1e-12)
    assert q[7] == pytest.approx(math.radians(0.1) ** 2 / 3600.0, rel=1e-12)


@pytest.mark.parametrize(("text", "cf"), [
    ("64", 64.0), ("SD", 64.0), ("summer day", 64.0), ("wd", 4.0), ("Winter  Day", 4.0),
    ("SN", 1.0), ("winter night", 1.0 / 2.25), ("0.5", 0.5),
])
def test_decca_cf_by_season_and_time_of_day(text: str, cf: float) -> None:
    """Decca.CF as the operator types it: A8.2's four conditions by code or name, or a number."""
    from engine.run.config import decca_cf_condition, parse_decca_cf

    assert parse_decca_cf(text) == cf
    assert decca_cf_condition(64.0) == "SD" and decca_cf_condition(1 / 2.25) == "WN"
    assert decca_cf_condition(2.0) is None


@pytest.mark.parametrize("text", ["", "0", "-4", "autumn", "1e2", "inf", "nan", "٦٤"])
def test_decca_cf_rejects(text: str) -> None:
    from engine.run.config import parse_decca_cf

    with pytest.raises(InputError, match='Decca.CF: "auto", a number > 0 or SD, WD, SN, WN !'):
        parse_decca_cf(text)


def test_empty_filter_table_is_the_honest_preset() -> None:
    """Issue 11: with no [filter] keys the filter is the honest one (coloured fix errors,
    physical P0, drifting biases); "thesis" is one key away and restores the thesis' three
    choices (L2291 white noise, L2670 P0 = I, L2639–2641 constant biases); a key set in the file
    wins over its preset; an unknown preset is located."""
    from engine.run.cycle import filter_params_from_config

    honest = parse_config_text("[filter]\n").filter
    assert (honest.preset, honest.model, honest.p0, honest.bias_noise) == (
        "honest", "coloured", "physical", True)
    assert honest == FilterConfig() == default_config().filter
    thesis = parse_config_text('[filter]\npreset = "Thesis"\n').filter
    assert (thesis.preset, thesis.model, thesis.p0, thesis.bias_noise) == (
        "thesis", "thesis", "thesis", False)
    assert thesis == FilterConfig.from_preset("thesis")
    mixed = parse_config_text('[filter]\npreset = "thesis"\nmodel = "coloured"\n').filter
    assert (mixed.model, mixed.p0) == ("coloured", "thesis")
    p = filter_params_from_config(parse_config_text(""))
    assert p.coloured and p.p0 == "physical" and p.bias_noise
    with pytest.raises(InputError) as caught:
        parse_config_text('[filter]\n\npreset = "faithful"\n', "x.toml")
    assert (caught.value.field, caught.value.line) == ("filter.preset", 3)


def test_current_random_walk_honest_and_thesis() -> None:
    """The honest current random walk is the thesis' tide (V_cm 1 m/s, period 45 000 s, §6.6)
    matched over an hour without fixes, THEORY §8.9; hand value: ω = 2π/45 000 = 1.39626·10⁻⁴
    rad/s, ωh = 0.502655, 1 − cos ωh = 0.123688, /3600 s = 3.4358·10⁻⁵ m²/s³, rounded up to
    3.5·10⁻⁵ (within 2 %); the thesis preset keeps §6.6's 2·10⁻⁸ (its tide's rate of change
    per 1-s step: ω² = 1.9496·10⁻⁸)."""
    from engine.filter.variances import current_rate_variance, tidal_current_psd
    from engine.run.cycle import filter_params_from_config

    assert tidal_current_psd(1.0, 45000.0, 3600.0) == pytest.approx(3.4358e-5, rel=1e-4)
    assert current_rate_variance(1.0, 45000.0) == pytest.approx(1.9496e-8, rel=1e-4)
    honest = filter_params_from_config(parse_config_text(""))
    assert honest.sigma_current2 == pytest.approx(3.4358e-5, rel=0.02)
    assert honest.sigma_current2 >= 3.4358e-5  # rounded up, not down
    thesis = filter_params_from_config(parse_config_text('[filter]\npreset = "thesis"\n'))
    assert thesis.sigma_current2 == 2e-8
    given = parse_config_text('[filter]\npreset = "thesis"\nsigma_current2 = 1e-6\n')
    assert given.filter.sigma_current2 == 1e-6


def test_vessel_preset_and_auto(tmp_path: Path) -> None:
    """``filter.vessel`` (docs/CONFIG.md "The vessel decision"): "surface" fills the keys the
    file leaves out, a key in the file wins; "auto" leaves a .RUN configuration exactly as it
    is (every 1993 run unchanged) and becomes "surface" for an NMEA log, again except for the
    keys the file set; an unknown vessel is located."""
    from engine.run.config import VESSEL_PRESETS, resolve_vessel
    from engine.run.cycle import filter_params_from_config

    surface = parse_config_text('[filter]\nvessel = "Surface"\nsigma_gyro_deg = 2.0\n').filter
    assert surface.vessel == "surface" and surface.sigma_gyro_deg == 2.0
    for key, value in VESSEL_PRESETS["surface"].items():
        if key != "sigma_gyro_deg":
            assert getattr(surface, key) == value, key
    assert FilterConfig.from_vessel("surface") == parse_config_text(
        '[filter]\nvessel = "surface"\n').filter
    p = filter_params_from_config(parse_config_text('[filter]\nvessel = "surface"\n'))
    assert (p.sigma_current2, p.turn_rate_max_deg_s) == (
        VESSEL_PRESETS["surface"]["sigma_current2"],
        VESSEL_PRESETS["surface"]["turn_rate_max_deg_s"])
    # "auto" with a .RUN (the bundled demo's configuration): the very same object.
    run = parse_config_text('run_file = "DEMO.RUN"\n', base_dir=ROOT / "data")
    assert run.filter.vessel == "auto" and resolve_vessel(run) is run
    assert filter_params_from_config(run) == filter_params_from_config(default_config())
    # "auto" with an NMEA log: surface, but the file's own key stays.
    (tmp_path / "y.nmea").write_text(
        "$GPRMC,120000,A,5250.0000,N,00430.0000,E,5.0,10.0,021226,,,A*47\n" * 3)
    text = 'run_file = "y.nmea"\n[filter]\nlog_sigma_frac = 0.02\n'
    auto = resolve_vessel(parse_config_text(text, base_dir=tmp_path)).filter
    assert auto.vessel == "surface" and auto.log_sigma_frac == 0.02
    assert auto.sigma_gyro_deg == VESSEL_PRESETS["surface"]["sigma_gyro_deg"]
    kept = resolve_vessel(parse_config_text(text + 'vessel = "submarine"\n',
                                            base_dir=tmp_path)).filter
    assert kept == FilterConfig(vessel="submarine")
    with pytest.raises(InputError) as caught:
        parse_config_text('[filter]\nvessel = "yacht"\n', "x.toml")
    assert (caught.value.field, caught.value.line) == ("filter.vessel", 2)


@pytest.mark.parametrize(("systems", "tau", "frac"), [
    # C/A: SA τ 240 s; white 5 m against 2500 m² × GPS.SE_SF 0.67 → 1 − 25/1675.
    ('[gps]\non = true\n', 240.0, 1.0 - 25.0 / 1675.0),
    # P: τ 600 s; white 0.5 m against 79.2 m² × 0.67 → 0.9953, capped at 0.99 (white floor 1 %).
    ('[gps]\non = true\nreceiver = "P"\n', 600.0, 0.99),
    # Decca only: sky-wave τ 180 s, white floor.
    ('[decca]\non = true\nred = "B20"\n', 180.0, 0.99),
    # Both: the longer τ, the smaller fraction.
    ('[gps]\non = true\n[decca]\non = true\nred = "B20"\n', 240.0, 1.0 - 25.0 / 1675.0),
    # GPS.SE_SF 0.04 makes the C/A σ 10 m: 1 − 25/100 = 0.75.
    ('[gps]\non = true\n[lsq]\ngps_se_sf = 0.04\n', 240.0, 0.75),
])
def test_auto_fix_model_follows_the_systems(systems: str, tau: float, frac: float) -> None:
    """fix_tau_s / fix_sigma_frac "auto" are derived from the receiver and chain (hand values
    from engine.filter.kalman's documented constants); a number in the file is used as it is."""
    from engine.run.cycle import filter_params_from_config

    p = filter_params_from_config(parse_config_text(systems))
    assert p.fix_tau_s == tau and p.fix_sigma_frac == pytest.approx(frac, abs=1e-12)
    given = parse_config_text(systems + '[filter]\nfix_tau_s = 60\nfix_sigma_frac = "AUTO"\n')
    assert given.filter.fix_sigma_frac == "auto"
    assert filter_params_from_config(given).fix_tau_s == 60.0
    with pytest.raises(InputError) as caught:
        parse_config_text('[filter]\nfix_tau_s = "soon"\n')
    assert caught.value.field == "filter.fix_tau_s"


def test_switching_the_preset_in_the_dialog_changes_only_what_the_preset_decides() -> None:
    """Demo ▸ Filter params, preset → "thesis": model, p0 and bias_noise follow the preset; a
    key changed earlier (q_scale 2) stays, since nobody edited it now."""
    from engine.run.commands import SetParameters, apply_command
    from engine.run.cycle import build_context, initial_state
    from engine.run.session import read_data_dir

    cfg = parse_config_text("[filter]\nq_scale = 2.0\n")
    ctx = build_context(cfg, *read_data_dir(ROOT / "data"))
    new, _nav, _text = apply_command(ctx, initial_state(cfg),
                                     SetParameters("filter", (("preset", "thesis"),)))
    f = new.filter
    assert (f.preset, f.model, f.p0, f.bias_noise, f.q_scale, f.sigma_current2) == (
        "thesis", "thesis", "thesis", False, 2.0, 2e-8)


def test_a_byte_order_mark_is_allowed(tmp_path: Path) -> None:
    """A configuration saved by a Windows editor starts with a UTF-8 byte-order mark, which
    TOML does not allow: it is dropped (such a file was refused as 'Invalid statement' on line
    1), and the line numbers of later messages are unchanged."""
    cfg = tmp_path / "bom.toml"
    cfg.write_bytes(b"\xef\xbb\xbf" + b'datum = "WGS84"\n[demo]\ndelta_t_s = 5\n')
    loaded = load_config(cfg)
    assert loaded.datum == "WGS84" and loaded.demo.delta_t_s == 5
    cfg.write_bytes(b"\xef\xbb\xbf" + b'datum = "WGS84"\n[demo]\ndelta_t_s = 0\n')
    with pytest.raises(InputError) as err:
        load_config(cfg)
    assert str(err.value).startswith(f"{cfg}:3: demo.delta_t_s: ")


@pytest.mark.parametrize(("text", "cf"), [
    ("", "auto"),  # the thesis' four conditions by the sun (L8352)
    ('[filter]\npreset = "thesis"\n', 64.0),  # the thesis program's summer's day (L8763)
    ('[filter]\npreset = "Thesis"\n[lsq]\ndecca_cf = 4\n', 4.0),  # the file's key wins
    ('[filter]\npreset = "thesis"\n[lsq]\ndecca_cf = "AUTO"\n', "auto"),
    ('[filter]\npreset = "honest"\n', "auto"),
    ('[lsq]\ndecca_cf = "winter night"\n', 1.0 / 2.25),
    ("[lsq]\ndecca_cf = 1\n", 1.0),
])
def test_decca_cf_auto_and_the_thesis_preset(text: str, cf: object) -> None:
    assert parse_config_text(text).lsq.decca_cf == cf


@pytest.mark.parametrize("value", ['"nightly"', '""', "true", "[64]"])
def test_bad_decca_cf_names_file_line_and_key(value: str) -> None:
    with pytest.raises(InputError) as caught:
        parse_config_text(f"[lsq]\nepsilon_m = 1.0\ndecca_cf = {value}\n", "mission.toml")
    err = caught.value
    assert (err.file, err.line, err.field) == ("mission.toml", 3, "lsq.decca_cf")
    assert '"auto"' in err.message
