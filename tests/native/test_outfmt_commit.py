"""The cycle's commit in the compiled ``engine.native.outfmt`` (issue 14): ``cycle_writer`` writes
a cycle's ``.OUT`` block straight to the log's descriptor, byte for byte the UTF-8 of
``cycle_text``'s str; ``freeze_result`` makes the arrays
:func:`engine.filter.estimate.freeze_result` makes read-only, in the same order, with the same
calls for anything that is not a plain array.

Compared with ``==``: the bytes of every block of three real replays, the flags of every array
(fresh, writable copies of a replay's fix and updates), the calls a duck object receives and the
error raised part-way; plus the session taking the direct write and its failure paths (a closed
descriptor, a full disk: the OSError names the ``.OUT``).
"""

from __future__ import annotations

import dataclasses
import errno
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from engine import native
from engine.fast import outlog as fast_outlog
from engine.filter.estimate import freeze_result
from engine.io import outlog
from engine.run.parts import REFERENCE, choose
from engine.run.records import BLOCK_SHAPES
from tests.native.replay import replay

K = native._load("outfmt")[0]
"""The built kernel (whatever ``UVNAV_PURE`` says), or None: the kernel tests are skipped."""
needs_kernel = pytest.mark.skipif(K is None, reason="engine.native.outfmt not built")


@pytest.fixture(scope="module")
def results() -> list[object]:
    """Cycle results of the demo, the thesis sample and the Markermeer NMEA log."""
    from tests.paths import DATA

    out: list[object] = []
    for cfg, n in ((DATA / "DEMO.toml", 120), (DATA / "920917_1.toml", 60),
                   (DATA / "nmea" / "avnav-markermeer-20160815.toml", 100)):
        out.extend(replay(n, cfg, history=1000).history)
    return out


def _read_all(fd: int) -> bytes:
    os.lseek(fd, 0, os.SEEK_SET)
    chunks = []
    while chunk := os.read(fd, 1 << 16):
        chunks.append(chunk)
    return b"".join(chunks)


@needs_kernel
def test_writer_writes_the_utf8_of_cycle_text(results: list[object], tmp_path: Path) -> None:
    """Every block of three replays: the bytes written are ``cycle_text(r)`` in UTF-8, and the
    count returned is their number; with ``repr`` only (no fast float writer) too."""
    assert len(results) > 200
    for dumps in (outlog._float_writer(), None):
        write = K.cycle_writer(BLOCK_SHAPES, dumps, outlog._format_text,
                               outlog.format_value)
        fd = os.open(tmp_path / f"w{dumps is None}", os.O_RDWR | os.O_CREAT | os.O_TRUNC)
        try:
            want = []
            for r in results:
                text = K.cycle_text(r, BLOCK_SHAPES, dumps, outlog._format_text,
                                    outlog.format_value)
                assert text is not None
                data = text.encode("utf-8")
                assert write(r, fd) == len(data)
                want.append(data)
            assert _read_all(fd) == b"".join(want)
        finally:
            os.close(fd)


@needs_kernel
def test_writer_declines_and_fails_as_the_python(results: list[object], tmp_path: Path) -> None:
    """A cycle the kernel leaves to the Python: None, nothing written; a non-ASCII message is
    written as its UTF-8; a closed descriptor: OSError EBADF; /dev/full: ENOSPC."""
    from dataclasses import replace

    write = fast_outlog.cycle_writer(BLOCK_SHAPES) or K.cycle_writer(
        BLOCK_SHAPES, outlog._float_writer(), outlog._format_text, outlog.format_value)
    path = tmp_path / "d.OUT"
    fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_TRUNC)
    try:
        assert write(object(), fd) is None
        assert write(replace(results[3], messages=("bad \udc80 text",)), fd) is None
        assert _read_all(fd) == b""
        r = replace(results[3], messages=("Δ 5° ✓", "naïve = 1"))
        assert write(r, fd) == len(K.cycle_text(r, BLOCK_SHAPES,
                                               outlog._float_writer(), outlog._format_text,
                                               outlog.format_value).encode())
        assert (_read_all(fd).decode("utf-8") == fast_outlog.cycle_text(r, BLOCK_SHAPES)
                or fast_outlog.kernel() is None)
    finally:
        os.close(fd)
    with pytest.raises(OSError) as info:
        write(results[3], fd)
    assert info.value.errno == errno.EBADF
    with pytest.raises(ValueError):
        write(results[3], -1)
    with pytest.raises(TypeError):
        write(results[3])
    if os.path.exists("/dev/full"):
        full = os.open("/dev/full", os.O_WRONLY)
        try:
            with pytest.raises(OSError) as info:
                write(results[3], full)
            assert info.value.errno == errno.ENOSPC
        finally:
            os.close(full)


@needs_kernel
def test_session_writes_directly_and_errors_name_the_log(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """The session writes each block through ``write_direct`` (the same file as through the
    text layers); after a write through the text buffer that failed, and after close, the
    direct path is not taken; a refused write names the ``.OUT``."""
    from engine.io.outlog import OutLogWriter
    from engine.run.config import load_config
    from engine.run.session import Session
    from tests.paths import DATA

    if fast_outlog.cycle_writer(BLOCK_SHAPES) is None:
        pytest.skip("UVNAV_PURE=1: the session writes through the text layers")
    calls = []
    real = OutLogWriter.write_direct

    def counted(self: OutLogWriter, write: object, item: object) -> bool:
        done = real(self, write, item)  # type: ignore[arg-type]
        calls.append(done)
        return done

    monkeypatch.setattr(OutLogWriter, "write_direct", counted)

    def run(name: str) -> str:
        out = tmp_path / f"{name}.OUT"
        cfg = load_config(DATA / "DEMO.toml")
        # adapt off: a cycle with an ADAPT line is written by the Python, not write_direct
        cfg = cfg.replace(filter=dataclasses.replace(cfg.filter, adapt=False))
        with Session(cfg, out_path=out, force=True, history=1) as s:
            s.run(max_cycles=30)
        return out.read_text(encoding="utf-8").split("# config-end\n", 1)[1]

    direct = run("direct")
    assert calls == [True] * 29  # the first block: the run's first-use check (cycle_text)
    monkeypatch.setattr(fast_outlog, "kernel", lambda: None)
    assert run("python") == direct
    assert len(calls) == 29

    log = OutLogWriter.create(tmp_path / "E.OUT")
    assert log._direct is not None
    bad_fd = os.open(os.devnull, os.O_RDONLY)
    log._direct = bad_fd  # a descriptor that refuses writes: the error names the log
    try:
        with pytest.raises(OSError) as info:
            log.write_direct(lambda r, fd: os.write(fd, b"x"), None)
    finally:
        os.close(bad_fd)
    assert info.value.filename == str(tmp_path / "E.OUT")
    log._direct = log._fd
    assert log.write_direct(lambda r, fd: None, None) is False
    assert log.write_direct(lambda r, fd: os.write(fd, b"CYCLE n=1\nEND n=1\n"), None)

    def failing(_text: str) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(log._fh, "write_flushed", failing)
    with pytest.raises(OSError):
        log.write_block("CYCLE n=2\nEND n=2\n")
    assert log._direct is None  # the text buffer may hold it: no write past it
    assert log.write_direct(lambda r, fd: os.write(fd, b"?"), None) is False
    monkeypatch.undo()
    log.close()
    assert log.write_direct(lambda r, fd: os.write(fd, b"?"), None) is False
    text = (tmp_path / "E.OUT").read_text(encoding="utf-8")
    assert text.endswith("# config-end\nCYCLE n=1\nEND n=1\n")


def _arrays() -> tuple[object, object, tuple[object, ...], list[np.ndarray]]:
    """A fix, Φ and two updates of fresh writable arrays (views among them, as update's
    l_inv and w are), and the list of those arrays in the order they are frozen."""
    rng = np.random.default_rng(7)
    order: list[np.ndarray] = []

    def a(*shape: int) -> np.ndarray:
        x = rng.normal(size=shape)
        order.append(x)
        return x

    fix = SimpleNamespace(cov=a(2, 2), ellipse=SimpleNamespace(eigenvectors=a(2, 2)),
                          raw_lops=SimpleNamespace(A=a(3, 2), omc_m=a(3), Cl=a(3, 3),
                                                   x_ref=a(2)))
    phi = a(4, 4)
    ups = []
    for _ in range(2):
        inn, S, K_ = a(3), a(3, 3), a(4, 3)
        Y = rng.normal(size=(3, 5))
        ls = SimpleNamespace(l_inv=Y[:, 2:], w=Y[:, 1])
        order.extend([ls.l_inv, ls.w])
        ups.append(SimpleNamespace(innovation=inn, S=S, K=K_, ls=ls))
    return fix, phi, tuple(ups), order


def _flags(x: np.ndarray) -> tuple[bool, ...]:
    return tuple(x.flags[k] for k in ("C_CONTIGUOUS", "F_CONTIGUOUS", "OWNDATA", "WRITEABLE",
                                      "ALIGNED", "WRITEBACKIFCOPY"))


@needs_kernel
def test_freeze_result_is_the_python(results: list[object]) -> None:
    """The kernel leaves exactly the flags the Python leaves, on constructed arrays (views,
    a subclass, no ellipse, no raw LOPs, no updates) and on a replay's own."""
    fix, phi, ups, order = _arrays()
    assert all(x.flags.writeable for x in order)
    assert K.freeze_result(fix, phi, *ups) is True
    assert not any(x.flags.writeable for x in order)
    fix2, phi2, ups2, order2 = _arrays()
    freeze_result(fix2, phi2, *ups2)
    for x, y in zip(order, order2, strict=True):
        assert _flags(x) == _flags(y)
    for x in (order2[-2], order2[-1]):
        assert x.base is not None and x.base.flags.writeable  # a view's base stays writable
    # None where the Python skips: no ellipse, no raw LOPs, no Φ, no updates
    fix3, _phi, _ups, order3 = _arrays()
    fix3.ellipse = None
    fix3.raw_lops = None
    assert K.freeze_result(fix3, None, None, None) is True
    assert [x.flags.writeable for x in order3[:6]] == [False, True, True, True, True, True]
    assert K.freeze_result(None, None, None, None) is True
    sub = np.eye(2).view(np.matrix)  # not an exact ndarray: through setflags
    K.freeze_result(None, sub, None, None)
    assert not sub.flags.writeable
    # a replay's results: everything already frozen by the cycle, and freezing again is a no-op
    for r in results[:20]:
        K.freeze_result(r.fix, None, r.filter_update, r.sensor_update)  # type: ignore


@needs_kernel
def test_freeze_result_calls_and_errors_as_the_python() -> None:
    """Anything that is not an exact ndarray gets ``setflags(write=False)`` (keyword) as from
    the Python; a missing attribute raises the Python's AttributeError after the same arrays
    were frozen; a wrong argument count is a TypeError."""
    log: list[tuple[str, tuple[object, ...], dict[str, object]]] = []

    class Duck:
        def __init__(self, name: str) -> None:
            self.name = name

        def setflags(self, *args: object, **kwargs: object) -> None:
            log.append((self.name, args, kwargs))

    def ducks() -> tuple[object, object, object]:
        fix = SimpleNamespace(cov=Duck("cov"), ellipse=SimpleNamespace(eigenvectors=Duck("ev")),
                              raw_lops=SimpleNamespace(A=Duck("A"), omc_m=Duck("omc"),
                                                       Cl=Duck("Cl"), x_ref=Duck("xr")))
        u = SimpleNamespace(innovation=Duck("v"), S=Duck("S"), K=Duck("K"),
                            ls=SimpleNamespace(l_inv=Duck("li"), w=Duck("w")))
        return fix, Duck("phi"), u

    fix, phi, u = ducks()
    K.freeze_result(fix, phi, u, None)
    got = list(log)
    log.clear()
    freeze_result(*ducks()[:2], ducks()[2], None)
    assert got == log and len(got) == 12
    assert all(kw == {"write": False} and not args for _n, args, kw in got)

    for remove in ("x_ref", "ls"):
        fix, phi, u = ducks()
        del (fix.raw_lops if remove == "x_ref" else u).__dict__[remove]
        log.clear()
        with pytest.raises(AttributeError) as k_err:
            K.freeze_result(fix, phi, u, None)
        k_log = list(log)
        log.clear()
        with pytest.raises(AttributeError) as p_err:
            freeze_result(fix, phi, u, None)
        assert k_log == log and str(k_err.value) == str(p_err.value)
    with pytest.raises(TypeError):
        K.freeze_result(None, None, None)


def test_cycle_takes_the_kernel_or_the_python() -> None:
    """The cycle freezes by the kernel where it is built and used (``UVNAV_PURE=1``: the
    Python), and the results are read-only either way (tests/run/test_cycle.py)."""
    s = replay(3)
    r = s.history[-1]
    assert not r.filter_update.K.flags.writeable  # type: ignore[union-attr]
    kernel = native.kernel("outfmt")
    assert (choose().freeze is REFERENCE.freeze) == (kernel is None)
