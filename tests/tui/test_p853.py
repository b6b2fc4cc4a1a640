"""Pg 853 shows H, R and ΓQΓᵀ of the cycle's update (it said ``n/a (not kept in the cycle
result)``): R of the LSE rows is the fix's VCV (Pg 641), H picks the position states, and the
speed entry of ΓQΓᵀ is σ_a² Δt of the white-acceleration model (thesis eq. 6.33)."""

from __future__ import annotations

import numpy as np
import pytest

from engine.api import Session, load_config, update_matrices
from tests.paths import DATA
from uvnav_tui.pages.p853_kalman_gain import render


def test_pg853_shows_h_r_and_process_noise() -> None:
    s = Session(load_config(DATA / "920917_1.toml"))
    results = []
    while (r := s.step()) is not None:
        results.append(r)
    r = results[5]
    text = render(r, s)
    assert "n/a" not in text
    assert "H (rows: measurement rows, columns: states)" in text
    lines = text.splitlines()
    h = lines.index("H (rows: measurement rows, columns: states)")
    assert lines[h + 2].split()[:3] == ["x_LSE", "1", "0"]
    assert lines[h + 3].split()[:3] == ["y_LSE", "0", "1"]
    u = r.filter_update
    parts = update_matrices(r.smoother_link[1].P, u.K, u.S, u.state.P)
    assert parts is not None
    assert parts[1] == pytest.approx(r.fix.cov * r.fix_cov_scale, rel=1e-9)
    rr = lines.index("R (measurement VCV, m² / (m/s)² / rad²)")
    assert float(lines[rr + 2].split()[1]) == pytest.approx(r.fix.cov[0, 0], abs=1e-3)
    q = lines.index(f"ΓQΓᵀ = P(k+1|k) − Φ P(k|k) Φᵀ over Δt = {r.dt_s:.1f} s")
    row_v = next(ln for ln in lines[q:] if ln.startswith("v "))
    sigma_a2 = s.context.filter_params.sigma_a2
    assert float(row_v.split()[4]) == pytest.approx(sigma_a2 * r.dt_s, rel=0.01)
    # the first cycle has no update: said so, ΓQΓᵀ still shown
    first = render(results[0], s)
    assert "K, H, R : n/a (no filter update this cycle)" in first
    assert np.isfinite(sigma_a2)
    s.close()
