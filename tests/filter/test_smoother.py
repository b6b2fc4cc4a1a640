"""RTS smoother (engine/filter/smoother.py, THEORY §11.1–11.2): invariants, the dive-shape property
and
an exact comparison with the batch (joint-Gaussian) conditional mean of the same linear model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.filter import kalman as kf
from engine.filter.smoother import SmootherRecord, rts_smooth

C_FIX = np.eye(2) * 900.0  # 30 m per axis


def _run(
    params: kf.FilterParams,
    n: int,
    fix_at: set[int],
    seed: int = 1,
    psi0: float = 1.0,
    psi_rate: float = 0.0,
) -> tuple[list[tuple], list[kf.Measurement], list[kf.FilterState]]:
    """Filter a straight 6.5 m/s track for n s (sensors every 1 s, LSE at ``fix_at`` epochs).

    Returns the smoother records, the measurements used and the filtered states.
    """
    rng = np.random.default_rng(seed)
    s = kf.init_state(0.0, 0.0, 0.0, 20.0, 6.5, psi0, 0.0, 0.1, -0.05, params, pos_cov=C_FIX)
    recs: list[tuple] = []
    meas: list[kf.Measurement] = []
    filt: list[kf.FilterState] = []
    for k in range(n + 1):
        if k:
            sp, phi = kf.predict_step(s, 1.0, params)
            recs.append((s, sp, phi))
            s = sp
        psi = (psi0 + psi_rate * k) % (2 * math.pi)
        tx, ty = 6.5 * k * math.sin(psi0) + 0.1 * k, 6.5 * k * math.cos(psi0) - 0.05 * k
        fix = None
        if k in fix_at:
            fix = (tx + 30.0 * rng.standard_normal(), ty + 30.0 * rng.standard_normal())
        m = kf.nav_measurement(
            s, params, fix_xy=fix, fix_cov=C_FIX, depth_m=20.0 + 1.45 * rng.standard_normal(),
            log_ms=6.5 + 0.13 * rng.standard_normal(),
            gyro_grid_rad=(psi + 0.011 * rng.standard_normal()) % (2 * math.pi))
        s = kf.update(s, m, params).state
        meas.append(m)
        filt.append(s)
    recs.append((s, None, None))  # recs[k] = (x̂_k|k, x̂_k+1|k, Φ_k)
    return recs, meas, filt


def test_last_epoch_unchanged_and_covariance_never_grows() -> None:
    p = kf.FilterParams(p0="physical")
    recs, _, filt = _run(p, 300, set(range(0, 100)) | set(range(200, 301)))
    sm = rts_smooth(recs)
    assert len(sm) == len(filt)
    np.testing.assert_array_equal(sm[-1].x, filt[-1].x)
    np.testing.assert_array_equal(sm[-1].P, filt[-1].P)
    for f, s in zip(filt, sm, strict=True):
        assert s.t == f.t
        # P_k|k − P_k|N is positive semi-definite (tolerance: rounding relative to |P|)
        assert np.linalg.eigvalsh(f.P - s.P).min() > -1e-9 * np.abs(f.P).max()
        assert 0.0 <= s.x[4] < 2 * math.pi


def _dive_sigmas(params: kf.FilterParams, dive: int) -> tuple[np.ndarray, np.ndarray]:
    """Radial position σ (m), filtered and smoothed: fixes for 100 s, a ``dive`` s without
    fixes (log, gyro, pressure continue), fixes again for 100 s."""
    n = 100 + dive + 100
    recs, _, filt = _run(params, n, set(range(0, 100)) | set(range(100 + dive, n + 1)))
    sm = rts_smooth(recs)
    sig_f = np.array([math.sqrt(f.P[0, 0] + f.P[1, 1]) for f in filt])
    sig_s = np.array([math.sqrt(s.P[0, 0] + s.P[1, 1]) for s in sm])
    return sig_f, sig_s


def test_dive_between_fixes_smoothed_sigma_peaks_mid_dive() -> None:
    """THEORY §11.1–11.2: "during a dive bracketed by two fixes, the smoothed σ is largest
    mid-dive". That needs a *random* DR error: with the A11 bias random walks (gyro 0.5°/√h,
    log 0.01 m/s/√h) and an 800-s dive, the smoothed σ peaks at the centre (±5 % of the dive),
    while the filter σ peaks at the last dived epoch."""
    dive = 800
    sig_f, sig_s = _dive_sigmas(kf.FilterParams(p0="physical", bias_noise=True), dive)
    w = slice(100, 100 + dive)
    assert 100 + int(np.argmax(sig_f[w])) == 99 + dive
    assert sig_f[99 + dive] > 10.0 * sig_f[99]
    peak = 100 + int(np.argmax(sig_s[w]))
    assert abs(peak - (100 + dive / 2)) <= 0.05 * dive, peak
    assert sig_s[peak] > 1.1 * max(sig_s[100], sig_s[99 + dive])
    assert np.all(sig_s <= sig_f + 1e-9)


def test_dive_with_constant_biases_smooths_like_a_regression() -> None:
    """With the thesis's random-constant biases (no bias noise) the DR drift over the dive is
    deterministic (constant current and biases, 1-Hz log and gyro), so the smoother acts like a
    straight-line fit through both fix clusters: its σ is *lowest* mid-dive (the centroid)
    and nearly flat. Recorded here because it qualifies the §12.5 expectation above."""
    dive = 400
    sig_f, sig_s = _dive_sigmas(kf.FilterParams(p0="physical"), dive)
    mid = sig_s[100 + dive // 2]
    assert mid < sig_s[100] and mid < sig_s[99 + dive]
    assert sig_s[100:100 + dive].max() < 1.5 * sig_s[100:100 + dive].min()
    assert sig_f[99 + dive] > 5.0 * sig_s[99 + dive]


def test_rts_equals_batch_conditional_mean_of_the_same_linear_model() -> None:
    """Independent check: stack x_0…x_N of the linear(ised) model the filter actually ran,
    x_k+1 = Φ_k x_k + u_k + η_k, η ~ N(0, Q_k), with u_k = x̂_k+1|k − Φ_k x̂_k|k (A7.6 pseudo
    input), and condition the joint Gaussian on all measurements at once. The RTS output must
    equal that batch posterior (mean to 1e-6 m-level, covariance to 1e-6 relative)."""
    p = kf.FilterParams(p0="physical")
    n = 30
    recs, meas, _ = _run(p, n, set(range(0, 10)) | {25, 30}, seed=3)
    N, d = n + 1, 11
    s0 = kf.init_state(0.0, 0.0, 0.0, 20.0, 6.5, 1.0, 0.0, 0.1, -0.05, p, pos_cov=C_FIX)
    mu = np.zeros(N * d)
    Sig = np.zeros((N * d, N * d))
    mu[:d] = s0.x
    Sig[:d, :d] = s0.P
    for k in range(n):
        filt_k, pred, phi = recs[k]
        u = pred.x - phi @ filt_k.x
        Q = kf.discrete_noise(filt_k.x, 1.0, p)
        a, b = k * d, (k + 1) * d
        mu[b:b + d] = phi @ mu[a:a + d] + u
        Sig[b:b + d, :b] = phi @ Sig[a:a + d, :b]
        Sig[:b, b:b + d] = Sig[b:b + d, :b].T
        Sig[b:b + d, b:b + d] = phi @ Sig[a:a + d, a:a + d] @ phi.T + Q
    rows = [m.z.shape[0] for m in meas]
    Hb = np.zeros((sum(rows), N * d))
    Rb = np.zeros((sum(rows), sum(rows)))
    y = np.zeros(sum(rows))
    i = 0
    for k, m in enumerate(meas):
        r = rows[k]
        Hb[i:i + r, k * d:(k + 1) * d] = m.H
        Rb[i:i + r, i:i + r] = m.R
        y[i:i + r] = m.z
        i += r
    S = Hb @ Sig @ Hb.T + Rb
    G = np.linalg.solve(S, Hb @ Sig).T
    post_mu = mu + G @ (y - Hb @ mu)
    post_P = Sig - G @ Hb @ Sig
    sm = rts_smooth(recs)
    for k in range(N):
        blk = slice(k * d, (k + 1) * d)
        np.testing.assert_allclose(sm[k].x, post_mu[blk], rtol=1e-9, atol=1e-6)
        np.testing.assert_allclose(sm[k].P, post_P[blk, blk], rtol=1e-6,
                                   atol=1e-6 * np.abs(post_P[blk, blk]).max())


def test_fix_states_added_mid_run() -> None:
    """Coloured model: GM fix states appear at the first fix (epoch 20); epochs before it keep
    11 states and are smoothed through the marginal of the later, larger state."""
    p = kf.FilterParams(p0="physical", coloured=True)
    recs, _, filt = _run(p, 120, set(range(20, 121)))
    sm = rts_smooth([SmootherRecord(*r) for r in recs])
    assert [s.n for s in sm] == [f.n for f in filt]
    assert sm[0].n == 11 and sm[-1].n == 13 and sm[-1].fix_states == ("fix_e", "fix_n")
    for f, s in zip(filt, sm, strict=True):
        assert np.linalg.eigvalsh(f.P - s.P).min() > -1e-9 * np.abs(f.P).max()
    # the early (pre-fix) positions profit from the later fixes
    assert sm[0].P[0, 0] < 0.75 * filt[0].P[0, 0]


def test_heading_through_north_is_wrapped() -> None:
    """Heading turning through 0/2π (0.05 °/s from 357°): smoothed ψ stays in [0, 2π) and
    within 5σ of the filtered one across the wrap."""
    p = kf.FilterParams(p0="physical")
    recs, _, filt = _run(p, 120, set(range(0, 121, 10)), psi0=357.0 * math.pi / 180,
                         psi_rate=0.05 * math.pi / 180)
    sm = rts_smooth(recs)
    crossed = False
    for f, s in zip(filt, sm, strict=True):
        assert 0.0 <= s.x[4] < 2 * math.pi
        dpsi = (s.x[4] - f.x[4] + math.pi) % (2 * math.pi) - math.pi
        assert abs(dpsi) < 5 * math.sqrt(f.P[4, 4])
        crossed |= f.x[4] < 1.0
    assert crossed


def test_inconsistent_records_are_rejected() -> None:
    p = kf.FilterParams()
    recs, _, _ = _run(p, 5, {0})
    with pytest.raises(ValueError):
        rts_smooth(recs[:2] + [(recs[3][0], None, None)])  # time gap
    with pytest.raises(ValueError):
        rts_smooth([(recs[0][0], None, None), recs[1]])  # missing prediction
    assert rts_smooth([]) == []


def test_spill_keeps_records_like_a_list(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """SmootherSpill (issue 15 item 9): append / replace_last / pop / clear behave as on a
    list, and newest_first reads every record back from the file unchanged."""
    from engine.filter.smoother import SmootherSpill

    recs, _m, _f = _run(kf.FilterParams(p0="physical"), 5, {2})
    spill = SmootherSpill(tmp_path)
    model: list[tuple[SmootherRecord, float]] = []
    for i, r in enumerate(recs):
        rec = _as_rec(r)
        spill.append(rec, float(i % 2))
        model.append((rec, float(i % 2)))
    spill.replace_last(_as_rec(recs[0]), 9.0)
    model[-1] = (_as_rec(recs[0]), 9.0)
    spill.pop()
    model.pop()
    spill.pop()
    model.pop()
    spill.append(_as_rec(recs[5]), 3.0)
    model.append((_as_rec(recs[5]), 3.0))
    assert len(spill) == len(model) == 5
    got = list(spill.newest_first())
    for (a, fa), (b, fb) in zip(got, reversed(model), strict=True):
        assert fa == fb and a.filtered.t == b.filtered.t
        np.testing.assert_array_equal(a.filtered.P, b.filtered.P)
    spill.clear()
    assert len(spill) == 0 and list(spill.newest_first()) == []
    spill.close()


def _as_rec(r: object) -> SmootherRecord:
    return r if isinstance(r, SmootherRecord) else SmootherRecord(*r)  # type: ignore[misc]


def test_spilled_session_smoothing_equals_the_in_memory_pass() -> None:
    """The session's streamed smoother (spill file, per-record grids, issue 15 item 9) gives the
    in-memory rts_smooth's answer on the same filter run: 900 s of the demo, whose CM changes
    from 5° to 4° at cycle 808, so records on two grids meet in the backward pass. By hand,
    every record is re-projected to the final grid first (the session's old eager method); the
    session now re-projects the smoothed state at the frame change instead, so each RTS step
    has its states and its Φ on one grid. From the change on the two are the same arithmetic;
    before it they differ by up to 8 cm (measured), because the eager method kept Φ of the old
    grid (headings and current 0.8° apart) with states re-projected to the new one."""
    import pathlib

    from engine.run.session import Session, load_run_config

    cfg, data = load_run_config(pathlib.Path(__file__).resolve().parents[2] / "data"
                                / "DEMO.toml")
    s = Session(cfg, data=data, collect_smoother=True, history=1)
    results = [s.step() for _ in range(900)]
    assert {r.cm_deg for r in results} == {5.0, 4.0}
    streamed = list(s.iter_smoothed())
    # The same records by hand, in memory, all on the final grid.
    from engine.run.cycle import reproject_state

    grid = s.context.grid(s.nav.cm_deg)
    recs: list[SmootherRecord] = []
    for r in results:
        if r.smoother_link is not None and recs:
            start, pred, phi = r.smoother_link
            recs[-1] = SmootherRecord(start, pred, phi)
            cm_link = r.cm_deg
            if cm_link != s.nav.cm_deg:
                old = s.context.grid(cm_link)
                recs[-1] = SmootherRecord(reproject_state(start, old, grid),
                                          reproject_state(pred, old, grid), phi)
        fs = r.filter_state
        if r.cm_deg != s.nav.cm_deg:
            fs = reproject_state(fs, s.context.grid(r.cm_deg), grid)
        recs.append(SmootherRecord(fs))
    by_hand = rts_smooth(recs)
    assert len(streamed) == len(by_hand) == len(results)
    worst = max(math.hypot(p.x_m - q.x[0], p.y_m - q.x[1]) for p, q in
                zip(streamed, by_hand, strict=True))
    change = next(i for i, r in enumerate(results) if r.cm_deg == 4.0)
    after = max(math.hypot(p.x_m - q.x[0], p.y_m - q.x[1]) for p, q in
                zip(streamed[change - 1:], by_hand[change - 1:], strict=True))
    assert after < 1e-6  # one grid: the same arithmetic
    assert worst < 0.1  # measured 0.079 m
    for p, q in zip(streamed, by_hand, strict=True):
        ref = q.P[:2, :2]  # within 0.5 % of its largest entry (measured 0.1 %)
        assert np.abs(p.cov - ref).max() <= 5e-3 * np.abs(ref).max()
    s.close()


def test_spill_memory_is_flat_in_the_run_length(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Issue 15 item 9: --smooth kept every epoch's records in memory (865 MB for 24 h). The
    spill keeps one record in memory whatever the count (traced peak within 64 kB)."""
    import tracemalloc

    from engine.filter.smoother import SmootherSpill

    recs, _m, _f = _run(kf.FilterParams(p0="physical"), 40, {5, 20})
    recs = [_as_rec(r) for r in recs]

    def peak(n: int) -> int:
        spill = SmootherSpill(tmp_path)
        tracemalloc.start()
        try:
            for i in range(n):
                spill.append(recs[i % len(recs)], 5.0)
            assert sum(1 for _ in spill.newest_first()) == n
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
            spill.close()

    assert peak(800) - peak(100) < 65_536


def _same_bits(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Equal shape, dtype and IEEE bytes (NaN payloads and −0.0 included)."""
    if a is None or b is None:
        return a is None and b is None
    return (a.shape == b.shape and a.dtype == b.dtype
            and np.array_equal(np.ascontiguousarray(a).view(np.uint8),
                               np.ascontiguousarray(b).view(np.uint8)))


def _same_float(a: object, b: object) -> bool:
    import struct

    if not isinstance(a, float):
        return type(a) is type(b) and a == b
    return type(a) is type(b) and struct.pack("<d", a) == struct.pack("<d", b)


def _same_state(a: kf.FilterState | None, b: kf.FilterState | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return (type(a) is type(b) and _same_float(a.t, b.t) and a.fix_states == b.fix_states
            and type(a.fix_states) is type(b.fix_states)
            and len(a.fix_tau_s) == len(b.fix_tau_s)
            and all(_same_float(u, v) for u, v in zip(a.fix_tau_s, b.fix_tau_s, strict=True))
            and _same_bits(a.x, b.x) and _same_bits(a.P, b.P)
            and _same_bits(a.fix_cov, b.fix_cov))


def _same_item(a: tuple[SmootherRecord, object], b: tuple[SmootherRecord, object]) -> bool:
    (ra, fa), (rb, fb) = a, b
    return (type(ra) is type(rb) and _same_float(fa, fb) and _same_state(ra.filtered, rb.filtered)
            and _same_state(ra.predicted_next, rb.predicted_next)
            and _same_bits(ra.phi, rb.phi))


def _odd_records() -> list[tuple[SmootherRecord, object]]:
    """Records the raw encoding must keep bit for bit, and some that fall back to pickle."""
    nan = np.frombuffer(bytes.fromhex("0100000000f8ff7f"), np.float64)[0]  # a payload
    assert math.isnan(nan)
    rng = np.random.default_rng(7)
    n = 13
    x = rng.standard_normal(n)
    x[[2, 5]] = (nan, -0.0)
    P = rng.standard_normal((n, n))
    P[0, 1], P[3, 3] = -0.0, math.nan
    cov = np.array([[900.0, -0.0], [math.nan, 1e-300]])
    with_fix = kf.FilterState(12.5, x, P, ("fix_e", "fix_n"), (600.0, -0.0), cov)
    pred = kf.FilterState(-0.0, x[::-1], P.T, ("fix_e", "fix_n"), (600.0, float(nan)), cov)
    bare = kf.FilterState(float(nan), x[:11], P[:11, :11])  # 0 fix states, fix_cov (0, 0)
    phi = np.asfortranarray(rng.standard_normal((n, n)))  # not C-contiguous
    phi[4, 4] = -0.0
    odd = kf.FilterState(1.0, x[:12], P[:12, :12], ("é — ß",), (), np.zeros((1, 1)))
    return [
        (SmootherRecord(with_fix, pred, phi), 5.0),
        (SmootherRecord(with_fix), -0.0),
        (SmootherRecord(bare), None),
        (SmootherRecord(bare, bare, np.eye(11)), float(nan)),
        (SmootherRecord(odd, None, np.zeros((0, 0))), math.inf),
        (SmootherRecord(with_fix, pred, phi), ("grid", 5)),  # not a float: pickle
        (SmootherRecord(bare), np.float64(4.0)),  # a float subclass: pickle
        (SmootherRecord(bare, bare, phi.astype(np.float32)), 4.0),  # float32 Φ: pickle
        (SmootherRecord(kf.FilterState(3, x, P, ("a", "b"), (1, 2.0), cov)), 1.0),  # int t
    ]


def test_spill_encoding_round_trips_bit_for_bit(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The spill's raw record encoding returns every field exactly (NaN payloads, −0.0, 0 and
    2 fix states, with and without prediction and Φ); what it does not cover (a frame that is
    not a float or None, a float32 Φ, an int t) goes through pickle, also exactly."""
    from engine.filter import smoother as sm

    items = _odd_records()
    tags = [sm._encode(it)[0] for it in items]
    assert tags == [sm._TAG_RAW] * 5 + [sm._TAG_PICKLE] * 4
    for it in items:
        assert _same_item(sm._decode(sm._encode(it)), it)
    spill = sm.SmootherSpill(tmp_path)
    for it in items:
        spill.append(*it)
    spill.append(*items[0])
    got = list(spill.newest_first())
    assert len(got) == len(items) + 1
    for a, b in zip(got[1:], reversed(items), strict=True):
        assert _same_item(a, b)
    spill.close()


def test_spill_interleaved_operations_match_a_list(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The spill seeks only when a read moved the file position: random appends, pops,
    replacements, clears and (partial) reads agree with a list, byte for byte."""
    from engine.filter.smoother import SmootherSpill

    items = _odd_records()
    rng = np.random.default_rng(3)
    spill = SmootherSpill(tmp_path)
    model: list[tuple[SmootherRecord, object]] = []
    for _ in range(600):
        op = rng.choice(["append"] * 6 + ["pop", "replace", "clear", "read", "peek"])
        it = items[int(rng.integers(len(items)))]
        if op == "append" or not model:
            spill.append(*it)
            model.append(it)
        elif op == "pop":
            spill.pop()
            model.pop()
        elif op == "replace":
            spill.replace_last(*it)
            model[-1] = it
        elif op == "clear" and rng.random() < 0.2:
            spill.clear()
            model.clear()
        elif op == "read":
            got = list(spill.newest_first())
            assert len(got) == len(model)
            assert all(_same_item(a, b) for a, b in zip(got, reversed(model), strict=True))
        elif op == "peek":  # a partial read, then an append
            gen = spill.newest_first()
            for a, b in zip(gen, reversed(model[-3:]), strict=False):
                assert _same_item(a, b)
            gen.close()
        assert len(spill) == len(model)
    got = list(spill.newest_first())
    assert all(_same_item(a, b) for a, b in zip(got, reversed(model), strict=True))
    spill.close()


def test_session_smoothing_is_identical_with_the_pickle_spill(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """600 demo cycles smoothed with the raw spill encoding and with every record pickled (the
    encoding before): every smoothed value is equal, exactly."""
    import dataclasses
    import pathlib

    from engine.filter import smoother as sm
    from engine.run.session import Session, load_run_config

    cfg, data = load_run_config(pathlib.Path(__file__).resolve().parents[2] / "data"
                                / "DEMO.toml")

    def smoothed() -> list:  # type: ignore[type-arg]
        s = Session(cfg, data=data, collect_smoother=True, history=1)
        for _ in range(600):
            s.step()
        out = list(s.iter_smoothed())
        s.close()
        return out

    tags: set[int] = set()

    def encode(item: tuple[SmootherRecord, object], memo: sm.MetaMemo | None = None) -> bytes:
        blob = encode_raw(item, memo)
        tags.add(blob[0])
        return blob

    encode_raw = sm._encode
    with monkeypatch.context() as m:
        m.setattr(sm, "_encode", encode)
        raw = smoothed()
    assert tags == {sm._TAG_RAW}  # every demo record takes the raw encoding
    with monkeypatch.context() as m:
        m.setattr(sm, "_encode", lambda item, memo=None: sm._pickled(item))
        pickled = smoothed()
    assert len(raw) == len(pickled) == 600
    for a, b in zip(raw, pickled, strict=True):
        assert (a.source, a.lat_deg, a.lon_deg, a.x_m, a.y_m, a.depth_m) == (
            b.source, b.lat_deg, b.lon_deg, b.x_m, b.y_m, b.depth_m)
        assert _same_bits(a.cov, b.cov)
        assert (a.ellipse is None) == (b.ellipse is None)
        if a.ellipse is not None:
            for f in dataclasses.fields(a.ellipse):
                u, v = getattr(a.ellipse, f.name), getattr(b.ellipse, f.name)
                assert _same_bits(u, v) if isinstance(u, np.ndarray) else _same_float(u, v)
