"""The half-zone warning of the Decca lane-count resolution (THEORY D7) in the processing cycle.

The thesis sample (920917_1.toml: Red B20, Green F34) resolves without a warning: at the DR
start N_calc = 44.88 / 276.15 against 44.862 / 274.337 (THEORY §3.3), well inside half a zone.
Entering Red one zone too far (C20) still resolves the 10-zone cycle to the count nearest the
DR (68.862 against 44.88, 24 lanes ≈ 10.5 km on the baseline) but is more than half a zone
(12 lanes) from it: the cycle's messages must carry the warning, once, on the first reading.
"""

from __future__ import annotations

from dataclasses import replace

from engine.run.config import RunConfig, load_config
from engine.run.session import Session
from tests.paths import DATA

SAMPLE = DATA / "920917_1.toml"


def _messages(cfg: RunConfig) -> list[tuple[str, ...]]:
    s = Session(cfg)
    out = []
    while (r := s.step()) is not None:
        out.append(r.messages)
    return out


def test_sample_zone_lanes_give_no_warning() -> None:
    assert not any("half a zone" in m for ms in _messages(load_config(SAMPLE)) for m in ms)


def test_zone_entered_one_zone_off_is_warned_once() -> None:
    cfg = load_config(SAMPLE)
    cfg = cfg.replace(decca=replace(cfg.decca, red="C20"))
    msgs = _messages(cfg)
    first = [m for m in msgs[0] if "half a zone" in m]
    assert len(first) == 1
    assert first[0].startswith("Decca red: zone/lane C20 gives 68.862 lanes, +2")
    assert "12 lanes" in first[0]
    # later readings are tracked from the first (decometer), not resolved again: no repeat
    assert not any("half a zone" in m for ms in msgs[1:] for m in ms)
