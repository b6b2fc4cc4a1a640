"""Every Demo-menu parameter (THEORY §12.6 item 7, §12.11, D36; issue 6 item 3) changes the next
cycle's result in the expected direction, and the change is written to the ``.OUT`` log.

Method: two sessions on the same configuration run the same records; before cycle ``K`` one of
them receives ``SetParameters`` (what Demo ▸ Parameters / Corrections / LS params / Filter params
send). Everything up to that cycle is identical, so any difference in cycle ``K`` comes from the
parameter alone. The expected effect is worked out independently of the engine where it can be
(χ² quantiles from scipy, the ×CF and ×SE_SF scaling of the a priori VCV, eq. 3.3 for depth);
otherwise the test asserts the direction the thesis describes.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.stats import chi2

from engine.io.outlog import read_out_log
from engine.lsq.fix import SLOT_GPS_LAT, SLOT_GPS_LON
from engine.run.commands import SetParameters
from engine.run.config import RunConfig, load_config
from engine.run.cycle import CycleResult
from engine.run.session import Session
from tests.paths import DATA

SAMPLE = DATA / "920917_1.toml"
K = 3
"""The cycle the change applies to (the sample run: GPS + Red + Green, four LOPs, category IV)."""
RED, GREEN = 2, 3
"""Observation slots of the Red and Green Decca LOPs (THEORY §5.3)."""


def twin(cfg: RunConfig, table: str, values: dict[str, Any], *, k: int = K,
         out: Path | None = None) -> tuple[CycleResult, CycleResult, Session]:
    """Cycle ``k`` of two identical runs of ``cfg``, the second with ``values`` set in
    ``[table]`` just before cycle ``k``; returns (base, changed, changed session)."""
    base = Session(cfg)
    changed = Session(cfg, out_path=out)
    for _ in range(k - 1):
        base.step()
        changed.step()
    changed.apply(SetParameters(table, tuple(values.items())))
    rb, rc = base.step(), changed.step()
    base.close()
    assert rb is not None and rc is not None and rb.n == rc.n == k
    return rb, rc, changed


@pytest.fixture(scope="module")
def sample() -> RunConfig:
    """The thesis start-up (GPS + Decca Red/Green, filter on)."""
    return load_config(SAMPLE)


def lse_axes(r: CycleResult, level: float) -> tuple[float, float]:
    """(a, b) in m of the cycle's LSE ellipse at ``level``."""
    assert r.fix is not None and r.fix.ellipse is not None
    return r.fix.ellipse.scaled(level)


def a_priori(r: CycleResult) -> np.ndarray:
    """The a priori VCV C_l of the cycle's fix over the ten slots (m²)."""
    assert r.fix is not None and r.fix.tested is not None
    return r.fix.tested.adjustment.Cl


def lop(r: CycleResult, slot: int) -> Any:
    """The LOP row of ``slot``."""
    assert r.fix is not None
    return next(row for row in r.fix.lops if row.slot == slot)


# ----------------------------------------------------------------------------- [lsq]
def test_conf_region_scales_the_displayed_axes_by_the_chi2_ratio(sample: RunConfig) -> None:
    """ConfRegion 95 → 99.9 %: a and b grow by sqrt(χ²₂(0.999) / χ²₂(0.95)) = 3.717 / 2.448
    (THEORY §12.8, L6807–6821); the fix itself does not change."""
    rb, rc, s = twin(sample, "lsq", {"conf_region_pct": 99.9})
    assert s.config.lsq.conf_region_pct == 99.9
    ratio = math.sqrt(chi2.ppf(0.999, 2) / chi2.ppf(0.95, 2))
    assert ratio == pytest.approx(3.717 / 2.4477, rel=1e-3)  # the thesis' k factors
    a95, b95 = lse_axes(rb, 0.95)
    a999, b999 = lse_axes(rc, s.config.lsq.conf_region_pct / 100)
    assert (a999 / a95, b999 / b95) == pytest.approx((ratio, ratio), rel=1e-9)
    assert (rc.fix.x_m, rc.fix.y_m) == (rb.fix.x_m, rb.fix.y_m)


def test_decca_cf_divides_the_sky_wave_part_of_the_decca_vcv(sample: RunConfig) -> None:
    """Decca.CF divides the sky-wave (co)variances and leaves the synchronisation variances
    alone (A4; THEORY §5.5: the sync part is not divided by CF). So C_Decca(CF) = S + B/CF with
    S diagonal: the covariances scale by exactly 64/4 = 16 from summer day (64) to winter day
    (4), the variances are affine in 1/CF — (C(1) − C(64)) / (C(4) − C(64)) = (1 − 1/64) /
    (1/4 − 1/64) = 4.2 — and every variance grows: the LSE ellipse grows."""
    rb, r4, _ = twin(sample, "lsq", {"decca_cf": 4.0})
    _, r1, _ = twin(sample, "lsq", {"decca_cf": 1.0})
    c64, c4, c1 = (a_priori(r)[np.ix_([RED, GREEN], [RED, GREEN])] for r in (rb, r4, r1))
    # C_l is evaluated at the last iterate, which differs between the runs by the change of the
    # fix (metres) over ship-station distances of 100-400 km: ~1e-5 relative, so 1e-4.
    assert c4[0, 1] == pytest.approx(16.0 * c64[0, 1], rel=1e-4)
    np.testing.assert_allclose(np.diag(c1 - c64) / np.diag(c4 - c64), 4.2, rtol=1e-4)
    assert np.all(np.diag(c4) > np.diag(c64))
    assert a_priori(r4)[SLOT_GPS_LAT, SLOT_GPS_LAT] == 2500.0
    assert lse_axes(r4, 0.95)[0] > lse_axes(rb, 0.95)[0]


def test_gps_se_sf_scales_the_gps_vcv(sample: RunConfig) -> None:
    """GPS.SE_SF 1 → 4: the GPS variances go from 2500 to 10000 m² (THEORY D5) and the
    LSE is less precise."""
    rb, rc, _ = twin(sample, "lsq", {"gps_se_sf": 4.0})
    for slot in (SLOT_GPS_LAT, SLOT_GPS_LON):
        assert a_priori(rb)[slot, slot] == 2500.0 and a_priori(rc)[slot, slot] == 10000.0
    assert rc.fix.cov[1, 1] > rb.fix.cov[1, 1] and rc.fix.cov[0, 0] > rb.fix.cov[0, 0]


def test_scale_vcv_multiplies_the_fix_vcv_by_s2(sample: RunConfig) -> None:
    """ScaleVCV on: C_x̂ is the a priori C_x̂ times the sample variance S² (eq. 5.13); the
    sample's S² is well below 1, so the ellipse shrinks."""
    rb, rc, _ = twin(sample, "lsq", {"scale_vcv": True})
    s2 = rb.fix.s2
    assert s2 is not None and 0.0 < s2 < 1.0 and rc.fix.s2 == pytest.approx(s2, rel=1e-12)
    np.testing.assert_allclose(rc.fix.cov, s2 * rb.fix.cov, rtol=1e-9)


def test_epsilon_stops_the_iteration_earlier(sample: RunConfig) -> None:
    """epsilon 1 m → 5 km: the Gauss-Newton loop stops after the first correction (every
    correction after the first is below 5 km); with 1 mm it needs at least as many."""
    rb, rc, _ = twin(sample, "lsq", {"epsilon_m": 5000.0})
    _, rfine, _ = twin(sample, "lsq", {"epsilon_m": 0.001})
    it = {name: r.fix.tested.adjustment.iterations for name, r in
          (("base", rb), ("coarse", rc), ("fine", rfine))}
    assert it["coarse"] == 1 <= it["base"] <= it["fine"]


def test_lop_reject_y_discards_a_blunder_and_n_keeps_it(tmp_path: Path,
                                                        sample: RunConfig) -> None:
    """LOPReject 'Y' rejects a GPS latitude 150 m off (|w| > 2.576) and iterates; 'N' keeps it
    and flags it (THEORY D16)."""
    lines = (DATA / "920917_1.RUN").read_text().splitlines()
    parts = lines[K].split()  # caption line first: record K is line K + 1
    assert parts[:2] == ["920917", "083540"]
    parts[4] = f"{float(parts[4]) + 150.0 / 30.9:.3f}"  # 150 m north (1" of latitude ≈ 30.9 m)
    lines[K] = " ".join(parts)
    run = tmp_path / "BLUNDER.RUN"
    run.write_text("\n".join(lines) + "\n")
    cfg = sample.replace(run_file=str(run))
    rn, ry, _ = twin(cfg.replace(lsq=dataclasses.replace(cfg.lsq, lop_reject="N")),
                     "lsq", {"lop_reject": "Y"})
    assert not lop(ry, SLOT_GPS_LAT).used and ry.fix.n_used == 3
    assert SLOT_GPS_LAT in ry.fix.rejected_slots
    assert lop(rn, SLOT_GPS_LAT).used and rn.fix.n_used == 4
    assert abs(lop(rn, SLOT_GPS_LAT).w) > 2.576
    assert SLOT_GPS_LAT in rn.fix.tested.flagged


def test_reliab_interval_changes_the_monitor_band_and_the_mdb(sample: RunConfig) -> None:
    """ReliabInterval 5 % → 1 %: the w-test's critical value goes from 1.960 to 2.576
    (two-sided normal quantiles) and every minimal detectable bias grows (a smaller α needs a
    larger bias for the same power)."""
    rb, rc, _ = twin(sample, "lsq", {"reliab_interval_pct": 1.0})
    mb = rb.fix.tested.adjustment.mdb
    mc = rc.fix.tested.adjustment.mdb
    used = [s for s in range(len(mb)) if math.isfinite(mb[s])]
    assert used
    for s in used:
        assert mc[s] > mb[s]


# ----------------------------------------------------------------------------- [corrections]
def test_decca_correction_is_added_to_the_reading(sample: RunConfig) -> None:
    """Corrections: +0.10 lanes on Red becomes the Red row's C-O (the reading itself is the same
    record) and the fix moves; Green keeps its own correction."""
    rb, rc, _ = twin(sample, "corrections", {"decca_red_lanes": 0.10})
    b, c = lop(rb, RED), lop(rc, RED)
    assert b.correction == sample.corrections.decca_red_lanes == -0.05  # the samples' C-O (A7)
    assert c.correction == 0.10 and c.read == b.read
    assert lop(rc, GREEN).correction == lop(rb, GREEN).correction


def test_gps_north_correction_moves_the_fix_north(sample: RunConfig) -> None:
    """Corrections: GPS +30 m north moves the GPS latitude LOP 30 m north and pulls the LSE
    north (by less than 30 m: the Decca LOPs hold it back)."""
    rb, rc, _ = twin(sample, "corrections", {"gps_north_m": 30.0})
    assert lop(rc, SLOT_GPS_LAT).correction == 30.0
    dy = rc.fix.y_m - rb.fix.y_m
    assert 0.0 < dy < 30.0


# ----------------------------------------------------------------------------- [filter]
def test_q_scale_inflates_the_prediction(sample: RunConfig) -> None:
    """Q scale 1 → 4: the filter's predicted position VCV (the KF row of Pg 641) grows."""
    rb, rc, _ = twin(sample, "filter", {"q_scale": 4.0})
    assert rb.kf_pred is not None and rc.kf_pred is not None
    assert np.trace(rc.kf_pred.cov) > np.trace(rb.kf_pred.cov)


# ----------------------------------------------------------------------------- [demo]
@pytest.fixture(scope="module")
def dived(tmp_path_factory: pytest.TempPathFactory) -> RunConfig:
    """Ten records of the demo at 20 m depth (pressure sensor on, no fixes)."""
    lines = (DATA / "DEMO.RUN").read_text().splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("920917 104819"))
    run = tmp_path_factory.mktemp("dived") / "DIVED.RUN"
    run.write_text("\n".join(lines[start:start + 10]) + "\n")
    return load_config(DATA / "DEMO.toml").replace(run_file=str(run))


def test_s_weight_scales_the_pressure_depth(dived: RunConfig) -> None:
    """Specific weight 1.026 → 1.000: the pressure depth d = (β/γ)(P − P_ref) (eq. 3.3) grows
    by exactly 1.026."""
    rb, rc, _ = twin(dived, "demo", {"s_weight": 1.0})
    db, dc = rb.sensors.depth_m, rc.sensors.depth_m
    assert db is not None and dc is not None and db > 15.0
    assert dc / db == pytest.approx(1.026, rel=1e-12)


def test_press_ref_freq_at_the_reading_gives_zero_depth(dived: RunConfig) -> None:
    """The surface reference set to the very frequency of the next record's reading: P = P_ref,
    so the depth is 0 (eq. 3.3)."""
    lines = Path(dived.run_path).read_text().splitlines()
    freq = float(lines[K - 1].split()[-2])
    rb, rc, _ = twin(dived, "demo", {"press_ref_freq_hz": freq})
    assert rb.sensors.depth_m is not None and rb.sensors.depth_m > 15.0
    assert rc.sensors.depth_m == pytest.approx(0.0, abs=1e-9)


def test_delta_t_processes_every_n_th_record(sample: RunConfig) -> None:
    """DeltaT 1 → 2 s: the next cycle is two records on, with a 2-s filter step (A21)."""
    rb, rc, _ = twin(sample, "demo", {"delta_t_s": 2})
    assert (rb.record, rb.dt_s) == (K + 1, 1.0)  # line 1 is the thesis caption
    assert rc.record == rb.record + 1 and rc.dt_s == 2.0
    assert (rc.time - rb.time).total_seconds() == 1.0


# ----------------------------------------------------------------------------- the .OUT log
@pytest.mark.parametrize(("table", "key", "value"), [
    ("lsq", "conf_region_pct", 99.9), ("lsq", "decca_cf", 4.0), ("lsq", "gps_se_sf", 2.0),
    ("lsq", "scale_vcv", True), ("lsq", "epsilon_m", 0.5), ("lsq", "lop_reject", "Y"),
    ("lsq", "reliab_interval_pct", 1.0), ("corrections", "decca_red_lanes", -0.05),
    ("filter", "q_scale", 2.0), ("demo", "s_weight", 1.025), ("demo", "delta_t_s", 2),
    ("demo", "plot_scale_m", 500.0), ("demo", "plot_size", 0.5),
    ("demo", "poe_expansion_m_h", 900.0), ("demo", "pace", "x10"),
])
def test_every_change_is_written_to_the_out_log(tmp_path: Path, sample: RunConfig, table: str,
                                                key: str, value: Any) -> None:
    """The change is an ``ACT`` line of the .OUT, before the cycle it applies to."""
    out = tmp_path / "P.OUT"
    _rb, _rc, s = twin(sample, table, {key: value}, out=out)
    s.close()
    log = read_out_log(out)
    acts = [a for a in log.actions if f"[{table}]" in a["text"] and f"{key}={value}" in a["text"]]
    assert len(acts) == 1 and acts[0]["cycle"] == K - 1
    assert [c.fields["n"] for c in log.cycles] == list(range(1, K + 1))


@pytest.fixture(autouse=True)
def _no_stray_logs() -> Iterator[None]:
    """The sessions here write no .OUT unless a test passes ``out``."""
    before = set(DATA.glob("*.OUT"))
    yield
    assert set(DATA.glob("*.OUT")) == before
