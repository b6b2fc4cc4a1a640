"""Damaged data files (issue 15): every damage either loads identically, fails with a located
message, or loads a different file that the run is warned about (checksum of the bundled file).

Two property tests over the bundled ``TO_WGS84.DAT`` and ``DECCA.CHN``, exhaustive rather than
sampled: the file cut at every byte, and every digit replaced by each of the nine others. For the
digit changes that pass every range check, the position effect is computed (a datum: the shift of
a point at 52.8° N 4.5° E to WGS84; a chain: the fix moved by the changed lane counts at that
point, through the lane gradients of engine.systems.decca; computed only for the printed table) and
every one must be flagged by :func:`engine.io.datafile_io.modified_bundled`.
``UVNAV_DAMAGE_TABLE=1`` prints the table of cases (docs/DATAFILES.md).
"""

from __future__ import annotations

import math
import os
import pathlib
from collections import Counter
from collections.abc import Callable

import numpy as np
import pytest

from engine.errors import InputError
from engine.geodesy.ellipsoid import WGS84
from engine.geodesy.ellipsoidal import GeodesicSolver, datum_shift
from engine.geodesy.tmgrid import TMGrid
from engine.io.datafile_io import BUNDLED_SHA256, modified_bundled, read_data_text
from engine.io.datumfile import DatumFile, parse_datum_text
from engine.io.deccafile import DeccaChain, parse_chain_text
from engine.systems.decca import decca_geometry, place_chain
from tests.paths import DATA

DAT_TEXT = (DATA / "TO_WGS84.DAT").read_text(encoding="utf-8")
CHN_TEXT = (DATA / "DECCA.CHN").read_text(encoding="utf-8")
DATUMS = parse_datum_text(DAT_TEXT, "TO_WGS84.DAT")
CHAINS = parse_chain_text(CHN_TEXT, "DECCA.CHN", known_datums=DATUMS.datums)
POINT = (52.8, 4.5)  # the demo area off Den Helder (ED50)
SHOW = os.environ.get("UVNAV_DAMAGE_TABLE") == "1"


def _parse_dat(text: str) -> DatumFile:
    return parse_datum_text(text, "TO_WGS84.DAT")


def _parse_chn(text: str) -> dict[str, DeccaChain]:
    return parse_chain_text(text, "DECCA.CHN", known_datums=DATUMS.datums)


def _datum_effect_m(df: DatumFile) -> float:
    """Largest change (m) of the WGS84 position of POINT over the datums of ``df``."""
    worst = 0.0
    for name, d in DATUMS.datums.items():
        new = df.datums.get(name)
        if new is None or new == d:
            continue
        a = datum_shift(d, WGS84).transform(*POINT, 0.0)
        b = datum_shift(new, WGS84).transform(*POINT, 0.0)
        dn = (b[0] - a[0]) * 111_000.0
        de = (b[1] - a[1]) * 111_000.0 * math.cos(math.radians(POINT[0]))
        worst = max(worst, math.hypot(dn, de))
    return worst


def _chain_effect_m(chains: dict[str, DeccaChain]) -> float:
    """Largest fix shift (m) at POINT from the changed lane counts, over chains and the three
    pattern pairs: δx = −R⁻¹ ΔN with R the 2×2 lane gradients (lanes/m)."""
    ell = DATUMS.datum("ED50").ellipsoid
    grid, geo = TMGrid(ell, 5.0), GeodesicSolver(ell)
    x, y = grid.forward(*POINT)
    worst = 0.0
    for cid, old in CHAINS.items():
        new = chains.get(cid)
        if new is None or new == old:
            continue
        g_old = decca_geometry(place_chain(old, grid), x, y, geo)
        g_new = decca_geometry(place_chain(new, grid), x, y, geo)
        dn = g_new.n_calc - g_old.n_calc
        for i, j in ((0, 1), (0, 2), (1, 2)):
            r = g_old.row[[i, j]]
            worst = max(worst, float(np.hypot(*np.linalg.solve(r, -dn[[i, j]]))))
    return worst


def _located(err: InputError, name: str, empty: bool = False) -> bool:
    """File, field and message named; a line too, unless the text is empty (no line to name)."""
    return (err.file == name and bool(err.field) and bool(err.message)
            and (empty or err.line is not None))


def _damage_table(
    name: str, text: str, parse: Callable[[str], object], effect: Callable[[object], float],
    tmp: pathlib.Path,
) -> dict[str, Counter[str]]:
    """Cut ``text`` at every byte and replace every digit by each other digit; classify."""
    original = parse(text)
    table: dict[str, Counter[str]] = {"cut": Counter(), "digit": Counter()}
    effects: list[tuple[float, str]] = []
    for cut in range(len(text) + 1):
        try:
            got = parse(text[:cut])
        except InputError as err:
            assert _located(err, name, empty=cut == 0), (cut, str(err))
            table["cut"]["error, located"] += 1
            continue
        assert got == original, f"cut at byte {cut} loads a different file"
        table["cut"]["identical"] += 1
    target = tmp / name
    for pos, ch in enumerate(text):
        if not ch.isdigit():
            continue
        for digit in "0123456789":
            if digit == ch:
                continue
            damaged = text[:pos] + digit + text[pos + 1:]
            try:
                got = parse(damaged)
            except InputError as err:
                assert _located(err, name), (pos, digit, str(err))
                table["digit"][f"error: {err.field}"] += 1
                continue
            if got == original:
                table["digit"]["identical (a comment)"] += 1
                continue
            target.write_text(damaged, encoding="utf-8")
            assert modified_bundled(target) is not None, (pos, digit)
            if not SHOW:  # the position effect is for the printed table only (slow)
                table["digit"]["accepted, warned (checksum)"] += 1
                continue
            e = effect(got)
            line = text.count("\n", 0, pos) + 1
            effects.append((e, f"line {line} col {pos - text.rfind(chr(10), 0, pos)}: "
                               f"{ch}->{digit}"))
            band = ("< 1 m" if e < 1 else "1-10 m" if e < 10 else "10-100 m" if e < 100
                    else "100-1000 m" if e < 1000 else ">= 1000 m")
            kind = "a name" if e == 0.0 else f"position {band}"
            table["digit"][f"accepted, warned (checksum), {kind}"] += 1
    if SHOW:
        print(f"\n{name}: {len(text)} bytes")
        for kind, counts in table.items():
            for outcome, n in sorted(counts.items()):
                print(f"  {kind:6s} {outcome:55s} {n:6d}")
        for e, where in sorted(effects, reverse=True)[:5]:
            print(f"  largest accepted: {e:10.2f} m  {where}")
    return table


def test_bundled_checksums_are_the_files() -> None:
    for name, digest in BUNDLED_SHA256.items():
        assert read_data_text(DATA / name).sha256 == digest
        assert modified_bundled(DATA / name) is None


def test_datum_file_damage(tmp_path: pathlib.Path) -> None:
    table = _damage_table("TO_WGS84.DAT", DAT_TEXT, _parse_dat, _datum_effect_m, tmp_path)
    # Only the whole file and the file without its last newline load: every other cut is
    # refused (the required end marker), at a line and field.
    assert table["cut"]["identical"] == 2
    assert table["cut"]["error, located"] == len(DAT_TEXT) - 1


def test_chain_file_damage(tmp_path: pathlib.Path) -> None:
    table = _damage_table("DECCA.CHN", CHN_TEXT, _parse_chn, _chain_effect_m, tmp_path)
    assert table["cut"]["identical"] == 2
    assert table["cut"]["error, located"] == len(CHN_TEXT) - 1


def test_issue_cut_at_byte_398_is_refused(tmp_path: pathlib.Path) -> None:
    # The issue's case: DECCA.CHN cut at byte 398 read the 9B speed as 29955 and the run
    # ended 24 km off with exit 0.
    (tmp_path / "DECCA.CHN").write_bytes((DATA / "DECCA.CHN").read_bytes()[:398])
    with pytest.raises(InputError) as info:
        from engine.io.deccafile import read_chain_file

        read_chain_file(tmp_path / "DECCA.CHN", known_datums=DATUMS.datums)
    assert info.value.file == str(tmp_path / "DECCA.CHN")
    assert info.value.line is not None and info.value.field is not None


# --------------------------------------------------------------------------- through the CLI


def _replay_with_data(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str],
                      datum: bytes | None = None, chain: bytes | None = None,
                      link_datum_to: str | None = None) -> tuple[int, str, pathlib.Path]:
    from uvnav_tui.cli.main import main

    d = tmp_path / "data"
    d.mkdir()
    if link_datum_to is not None:
        (d / "TO_WGS84.DAT").symlink_to(link_datum_to)
    else:
        (d / "TO_WGS84.DAT").write_bytes(datum or (DATA / "TO_WGS84.DAT").read_bytes())
    (d / "DECCA.CHN").write_bytes(chain or (DATA / "DECCA.CHN").read_bytes())
    text = (DATA / "920917_1.toml").read_text(encoding="utf-8")
    text = text.replace('data_dir = "."', f'data_dir = "{d}"').replace(
        'run_file = "920917_1.RUN"', f'run_file = "{DATA / "920917_1.RUN"}"')
    cfg = tmp_path / "R.toml"
    cfg.write_text(text, encoding="utf-8")
    out = tmp_path / "R.OUT"
    rc = main(["replay", str(DATA / "920917_1.RUN"), "--config", str(cfg), "--out", str(out)])
    return rc, capsys.readouterr().err, d


def test_replay_refuses_the_issues_cut_chain_file(tmp_path: pathlib.Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    chain = (DATA / "DECCA.CHN").read_bytes()[:398]
    rc, err, d = _replay_with_data(tmp_path, capsys, chain=chain)
    assert rc == 2 and "Traceback" not in err
    assert f"{d / 'DECCA.CHN'}:22: propagation speed: Propagation speed must be in" in err
    assert not (tmp_path / "R.OUT").exists()


def test_replay_refuses_a_datum_file_linked_to_dev_zero(
        tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Issue 15 item 7: it read until MemoryError.
    rc, err, d = _replay_with_data(tmp_path, capsys, link_datum_to="/dev/zero")
    assert rc == 2 and f"{d / 'TO_WGS84.DAT'}: Not a regular file !" in err
    assert "Traceback" not in err


def test_replay_refuses_an_oversized_datum_file(tmp_path: pathlib.Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    big = (DATA / "TO_WGS84.DAT").read_bytes() + b"*" * (1 << 20)
    rc, err, d = _replay_with_data(tmp_path, capsys, datum=big)
    assert rc == 2 and "File too large (more than 1048576 bytes) !" in err


def test_replay_warns_about_a_modified_but_valid_chain_file(
        tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    # One digit of the Hoyer seconds (0.01″, 30 cm): inside every range, so only the checksum
    # can tell. The run goes on, warned on stderr and in the .OUT header.
    chain = (DATA / "DECCA.CHN").read_bytes().replace(b"08 41 38.420", b"08 41 38.430")
    rc, err, d = _replay_with_data(tmp_path, capsys, chain=chain)
    assert rc == 0
    assert f"uvnav replay: warning: {d / 'DECCA.CHN'}: differs from the bundled DECCA.CHN" in err
    from engine.io.outlog import read_out_log

    header = read_out_log(tmp_path / "R.OUT").header
    assert any(h.startswith(f"warning {d / 'DECCA.CHN'}: differs") for h in header)
