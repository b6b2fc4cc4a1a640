"""``.OUT`` logs cut at every byte read back (issue 15 items 9–10).

A log cut anywhere (a crash, a full disk, a copy interrupted) must read back as the complete
cycles before the cut, with ``truncated`` set exactly when the cut is not at the end of a
complete item, and never raise: not inside a UTF-8 character, not after ``B``, ``BA`` or
``CYCL``. The expected outcome is computed from the text independently of the reader.
"""

from __future__ import annotations

import pathlib

import pytest

from engine.io.outlog import OutLogWriter, iter_out_log, read_out_log
from engine.run.session import Session, load_run_config
from tests.paths import DATA


def _synthetic(path: pathlib.Path) -> None:
    """A small log with multi-byte UTF-8 text in every kind of line."""
    with OutLogWriter.create(path, header=["engine test", "run Ωmega.RUN"],
                             config_text='datum = "ED50"\n# ½ comment', force=True) as w:
        w.write_action({"cycle": 0, "text": "Setup ▸ Systems ▸ GPS on"})
        w.write_cycle({"n": 1, "t": "1992-09-17T08:35:38Z"},
                      [("IN", {"raw": "920917 083538"}), ("MSG", {"text": "CM changed to +4°"})])
        w.write_bad_record({"record": 3, "field": "time", "message": "Time does not advance !",
                            "raw": "bad «record»"})
        w.write_cycle({"n": 2, "t": "1992-09-17T08:35:39Z"},
                      [("MPP", {"x": 1.5, "y": -2.25}), ("MSG", {"text": "σ ≤ 3 m"})])
        w.write_action({"cycle": 2, "text": "Kalman ▸ Filtering"})


def _expected(data: bytes) -> dict[int, tuple[int, bool]]:
    """For every cut k: (complete cycles before k, truncated), from the bytes alone."""
    closed_at = {0: True}
    cycles_at = {0: 0}
    pos, open_cycle, in_config, cycles = 0, False, False, 0
    for raw in data.splitlines(keepends=True):
        line = raw.decode("utf-8").rstrip("\n")
        pos += len(raw)
        if line == "# config-begin":
            in_config = True
        elif line == "# config-end":
            in_config = False
        elif line.startswith("CYCLE"):
            open_cycle = True
        elif line.startswith("END"):
            open_cycle, cycles = False, cycles + 1
        closed_at[pos] = not open_cycle and not in_config
        cycles_at[pos] = cycles
    out = {}
    last_end, last_cycles = 0, 0
    for k in range(len(data) + 1):
        if k in cycles_at:
            last_end, last_cycles = k, cycles_at[k]
        out[k] = (last_cycles, not (k == last_end and closed_at[k]))
    return out


def _check_every_cut(full: pathlib.Path, tmp_path: pathlib.Path) -> int:
    data = full.read_bytes()
    whole = read_out_log(full)
    cycles = list(whole.cycles)
    expected = _expected(data)
    cut = tmp_path / "CUT.OUT"
    multibyte_cuts = 0
    for k in range(len(data) + 1):
        cut.write_bytes(data[:k])
        log = read_out_log(cut)  # never raises
        n, truncated = expected[k]
        assert len(log.cycles) == n, k
        assert repr(list(log.cycles)) == repr(cycles[:n]), k  # repr: NaN fields compare
        assert log.truncated == truncated, k
        if truncated:
            assert log.problems and "incomplete" in log.problems[-1]
        if k < len(data) and (data[k] & 0xC0) == 0x80:
            multibyte_cuts += 1  # the cut split a UTF-8 character
    return multibyte_cuts


def test_synthetic_log_cut_at_every_byte(tmp_path: pathlib.Path) -> None:
    full = tmp_path / "S.OUT"
    _synthetic(full)
    assert _check_every_cut(full, tmp_path) >= 14  # cuts inside a multi-byte character


def test_replay_log_cut_at_every_byte(tmp_path: pathlib.Path) -> None:
    cfg, data = load_run_config(DATA / "920917_1.toml")
    full = tmp_path / "R.OUT"
    with Session(cfg, data=data, out_path=full, history=1) as s:
        s.run(max_cycles=1)  # a real header (the TOML) and a full cycle block, ~3.6 kB
    _check_every_cut(full, tmp_path)


@pytest.mark.parametrize("tail", [b"B", b"BA", b"CYCL", b"END n=", b"CYCLE n=3 t=\xc2",
                                  b"  MSG text=\"\xe2\x96"])
def test_cut_after_partial_tag_or_character(tmp_path: pathlib.Path, tail: bytes) -> None:
    # The cases: "unknown line tag" and UnicodeDecodeError before.
    full = tmp_path / "S.OUT"
    _synthetic(full)
    p = tmp_path / "T.OUT"
    p.write_bytes(full.read_bytes() + tail)
    log = read_out_log(p)
    assert log.truncated and len(log.cycles) == 2
    assert log.problems[-1].startswith(f"{p}:")


def test_streaming_reader_matches(tmp_path: pathlib.Path) -> None:
    full = tmp_path / "S.OUT"
    _synthetic(full)
    state, events = iter_out_log(full)
    got = list(events)
    whole = read_out_log(full)
    assert [c for k, c in got if k == "cycle"] == list(whole.cycles)
    assert [a for k, a in got if k == "action"] == list(whole.actions)
    assert [b for k, b in got if k == "bad"] == list(whole.bad_records)
    assert tuple(state.header) == whole.header and not state.truncated
    assert whole.cycles[-1] == whole.cycles[1] and whole.cycles[0:1] == [whole.cycles[0]]


def _log_with_cycles(path: pathlib.Path, n: int) -> None:
    with OutLogWriter.create(path, header=["engine test"], config_text="", force=True) as w:
        for i in range(1, n + 1):
            w.write_cycle({"n": i, "t": "1992-09-17T08:35:38Z"},
                          [("MPP", {"x": 1.5 * i, "y": -2.25, "a95": 3.0, "b95": 2.0}),
                           ("MSG", {"text": "a message of some length " * 4})])


def _peak_bytes(fn: object) -> int:
    import tracemalloc

    tracemalloc.start()
    try:
        fn()  # type: ignore[operator]
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_reading_memory_is_flat_in_the_run_length(tmp_path: pathlib.Path) -> None:
    # Issue 15 item 9: read_out_log held every cycle (1.73 GB for 24 h). Now 8 bytes per
    # cycle stay (the offsets): 4× the cycles may add at most 8 B per extra cycle plus 16 kB.
    small, large = tmp_path / "S.OUT", tmp_path / "L.OUT"
    _log_with_cycles(small, 500)
    _log_with_cycles(large, 2000)

    def walk(p: pathlib.Path) -> None:
        log = read_out_log(p)
        assert sum(1 for _c in log.cycles) == len(log.cycles)

    def stream(p: pathlib.Path) -> None:
        _state, events = iter_out_log(p)
        for _e in events:
            pass

    for fn in (walk, stream):
        grow = _peak_bytes(lambda fn=fn: fn(large)) - _peak_bytes(lambda fn=fn: fn(small))
        assert grow < 8 * 1500 + 16_384, (fn.__name__, grow)
