"""This tree against the pinned baseline engine, side by side: one table per ``make bench`` run.

Run with ``make bench`` (every bench) or ``make bench-baseline`` (this one; ``--doc
docs/PERFORMANCE.md`` also writes the table into that page between its
``<!-- bench_baseline:begin -->`` and ``<!-- bench_baseline:end -->`` markers).

What is compared: ``uvnav`` of this tree (its compiled path, as a user runs it) against
``uvnav`` of the commit :data:`BASELINE` (the engine whose speed is the bar), on each Python of
:func:`pythons` (the oldest supported, the interpreter of the main venv, and the newest the
machine offers, ``.ci/newest-python``). A Python that is not installed, or a tree that cannot
be prepared on it, is skipped with the reason printed.

The baseline is prepared from git, on a clean clone too: ``git archive`` of the commit into
``<tmp>/uvnav-bench-baseline-<commit>/src`` (once), and per Python a venv beside it,
``venv-<x.y.z>``, with ``pip install -e src`` (its kernels are built in place; their ``.so``
files carry the interpreter's tag, so the Pythons' builds sit side by side). The venv gets the
same versions of numpy, SciPy, pyproj, … as this tree's venv on that Python (its ``pip
freeze`` as constraints), so the engines differ and the libraries do not; if that resolution
fails the baseline gets PyPI's newest and the table says so. Everything is cached (a venv is
reused while this tree's library versions are those it was built with); the first run takes a
few minutes to build, later runs only measure. This tree runs from the repo's own venvs:
``.venv`` (``make venv``) and ``.venv-<x.y>`` (``make venv-new``; ``make bench`` builds both).

The workloads, each a fresh ``uvnav`` process with a warm bytecode cache (one untimed run of
each variant first; ``PYTHONPYCACHEPREFIX`` in a folder of this run):

* ``uvnav replay data/920917_1.RUN --no-out`` (the thesis sample; target ≤ 0.5 s, of which
  most is the start-up);
* ``uvnav replay`` of the first :data:`DEMO_EPOCHS` demo epochs with the ``.OUT`` written;
* ``uvnav replay`` of the 24 h mission of :mod:`bench.bench_long` (simulated once, cached)
  with the ``.OUT``;
* the console's first paint in tmux (:func:`bench.bench_startup.first_paint_once`; target
  ≤ 0.6 s wall).

Each round runs every workload once per (Python, variant), baseline and this tree alternating,
so a slow minute of a shared machine falls on both; medians over :data:`ROUNDS` rounds
(:data:`LONG_ROUNDS` for the 24 h mission, ~9 s a replay). The replays' figure is the CPU time
of the child process (user + system, ``getrusage(RUSAGE_CHILDREN)`` around it), which a shared
machine's load hardly moves; the wall time is printed beside it. The first paint is a wall time
(its CPU time is printed beside it).

A variant that fails (the process exits non-zero) is run once per workload, reported with the
last line of its error and not timed again. Where the baseline's compiled path fails on a
Python, its pure-Python path (``UVNAV_PURE=1``) is timed on that Python too, for the record
(once on the 24 h mission), and the ratio there is taken against the baseline's compiled path
on the oldest Python, where it works: "no slower than today's" means today's fastest working
engine on this machine, and the pure path, several times slower, would flatter any compiled
path.
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from bench import bench_long, bench_startup, child_env

ROOT = Path(__file__).resolve().parents[1]
BASELINE = "f4200bb"
"""The pinned baseline: the engine of C kernels on private interfaces, before the compiled path
was rebuilt on public ones."""
ROUNDS = 5
LONG_ROUNDS = 3
DEMO_EPOCHS = 1500
PURE_ENV = "UVNAV_PURE"
DOC_BEGIN = "<!-- bench_baseline:begin -->"
DOC_END = "<!-- bench_baseline:end -->"
THIS = "this tree"
BASE = "baseline"
BASE_PURE = "baseline pure"


class Unavailable(Exception):
    """A tree or a Python that cannot be measured here; the message says why."""


@dataclass(frozen=True)
class Workload:
    """One thing timed: ``name`` in the table, its ``target`` (text), rounds, and whether its
    figure is wall time (first paint) or CPU time (replays)."""

    key: str
    name: str
    target: str
    rounds: int
    wall: bool = False


WORKLOADS = (
    Workload("thesis", "`replay data/920917_1.RUN` (thesis sample)", "≤ 0.5 s", ROUNDS),
    Workload("demo", f"`replay` of {DEMO_EPOCHS} demo epochs, .OUT written", "", ROUNDS),
    Workload("long", "`replay` of the 24 h mission (86,400 epochs), .OUT written", "≤ 10 s",
             LONG_ROUNDS),
    Workload("paint", "console first paint (tmux 160×50), wall", "≤ 0.6 s", ROUNDS, wall=True),
)


@dataclass
class Variant:
    """One engine on one Python: its interpreter, its source tree (the working directory of
    its ``uvnav``), and whether it runs with ``UVNAV_PURE=1``."""

    label: str
    python: Path
    tree: Path
    pure: bool = False
    runs: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    failed: dict[str, str] = field(default_factory=dict)

    def env(self, pycache: Path) -> dict[str, str]:
        env = child_env(pycache)
        env.pop(PURE_ENV, None)
        if self.pure:
            env[PURE_ENV] = "1"
        return env


# ---------------------------------------------------------------- the Pythons and the trees


def _version(python: Path | str) -> str | None:
    """``x.y.z`` of the interpreter ``python``, or None if it does not run."""
    try:
        out = subprocess.run([str(python), "-c", "import sys; print('%d.%d.%d' % "
                              "sys.version_info[:3])"], capture_output=True, text=True,
                             timeout=60, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return out or None


def _minor(version: str) -> str:
    return ".".join(version.split(".")[:2])


def pythons() -> list[tuple[str, Path]]:
    """(x.y.z, base interpreter) of the Pythons compared: the one running this bench (the main
    venv's, the oldest supported) and the newest the machine offers (``.ci/newest-python``),
    that one only if it differs."""
    base = Path(getattr(sys, "_base_executable", sys.executable))
    found = [(_version(base) or platform.python_version(), base)]
    try:
        newest = subprocess.run([str(ROOT / ".ci" / "newest-python")], capture_output=True,
                                text=True, timeout=60).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        newest = ""
    v = _version(newest) if newest else None
    if v and _minor(v) != _minor(found[0][0]):
        found.append((v, Path(newest)))
    return found


def this_tree_python(version: str) -> Path:
    """This tree's venv interpreter on Python ``version`` (``.venv`` or ``.venv-x.y``)."""
    for venv in (ROOT / ".venv", ROOT / f".venv-{_minor(version)}"):
        py = venv / "bin" / "python"
        if py.exists() and _minor(_version(py) or "") == _minor(version):
            return py
    raise Unavailable(f"no venv of this tree on Python {_minor(version)} "
                      f"(`make venv-new PYTHON_NEW=<python{_minor(version)}>`)")


def _git(*args: str) -> str:
    try:
        done = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True,
                              timeout=120)
    except OSError as exc:
        raise Unavailable(f"git not usable ({exc})") from exc
    if done.returncode != 0:
        raise Unavailable(f"git {' '.join(args)}: {done.stderr.strip() or done.returncode}")
    return done.stdout


def baseline_commit(rev: str = BASELINE) -> str:
    """The full hash of ``rev``; :class:`Unavailable` if this checkout does not have it (no git,
    a shallow clone, an archive)."""
    try:
        return _git("rev-parse", "--verify", "--quiet", f"{rev}^{{commit}}").strip()
    except Unavailable as exc:
        raise Unavailable(f"baseline {rev} is not in this checkout's history ({exc}); "
                          "a shallow clone needs `git fetch --unshallow`") from exc


def baseline_dir(commit: str) -> Path:
    """The cache folder of the baseline ``commit`` (its source tree and its venvs)."""
    return Path(tempfile.gettempdir()) / f"uvnav-bench-baseline-{commit[:12]}"


def baseline_source(commit: str) -> Path:
    """The baseline's source tree, extracted once by ``git archive``."""
    src = baseline_dir(commit) / "src"
    if (src / ".complete").exists():
        return src
    tar = baseline_dir(commit) / "src.tar"
    tar.parent.mkdir(parents=True, exist_ok=True)
    _git("archive", "--format=tar", "-o", str(tar), commit)
    shutil.rmtree(src, ignore_errors=True)
    with tarfile.open(tar) as tf:
        tf.extractall(src, filter="data")
    tar.unlink()
    (src / ".complete").touch()
    return src


def _run_checked(cmd: list[str], what: str, timeout: float = 1800) -> str:
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except (OSError, subprocess.SubprocessError) as exc:
        raise Unavailable(f"{what}: {exc}") from exc
    if done.returncode != 0:
        tail = " | ".join((done.stderr or done.stdout).strip().splitlines()[-3:])
        raise Unavailable(f"{what} failed ({done.returncode}): {tail}")
    return done.stdout


def constraints(this_python: Path | None) -> list[str]:
    """``pip freeze`` of this tree's venv (this tree excluded): the library versions the
    baseline's venv is held to."""
    if this_python is None:
        return []
    out = _run_checked([str(this_python), "-m", "pip", "freeze", "--exclude-editable"],
                       "pip freeze", timeout=120)
    return [ln for ln in out.splitlines()
            if ln and not ln.startswith(("#", "-e ", "uvnav")) and " @ " not in ln]


def baseline_python(commit: str, version: str, base_python: Path,
                    pins: list[str]) -> tuple[Path, str]:
    """The interpreter of the baseline's venv on Python ``version`` (built once: ``python -m
    venv``, ``pip install -e src`` with ``pins`` as constraints, unconstrained if they do not
    resolve) and a note on the libraries it got. A cached venv is reused while this tree's
    versions are those it was built with (its ``constraints.txt``), else built again."""
    src = baseline_source(commit)
    venv = baseline_dir(commit) / f"venv-{version}"
    py = venv / "bin" / "python"
    note_file, cfile = venv / ".complete", venv / "constraints.txt"
    pin_text = "".join(f"{ln}\n" for ln in pins)
    if note_file.exists() and py.exists() and (
            cfile.read_text() if cfile.exists() else "") == pin_text:
        return py, note_file.read_text().strip()
    shutil.rmtree(venv, ignore_errors=True)
    print(f"  preparing the baseline {commit[:7]} on Python {version} in {venv} "
          "(venv, pip install -e, its kernels built; again when this tree's library versions "
          "change) …", flush=True)
    _run_checked([str(base_python), "-m", "venv", str(venv)], f"python{version} -m venv")
    pip = [str(py), "-m", "pip", "install", "--quiet", "--disable-pip-version-check"]
    note = "same library versions as this tree"
    if pins:
        cfile.write_text(pin_text)
        try:
            _run_checked([*pip, "-c", str(cfile), "-e", str(src)], "pip install (pinned)")
        except Unavailable as exc:
            note = f"libraries unpinned (this tree's versions did not resolve: {exc})"
            _run_checked([*pip, "-e", str(src)], "pip install -e (baseline)")
    else:
        note = "libraries: PyPI's newest (no venv of this tree on this Python to pin to)"
        _run_checked([*pip, "-e", str(src)], "pip install -e (baseline)")
    note_file.write_text(note + "\n")
    return py, note


def kernels_line(python: Path, tree: Path) -> str:
    """``uvnav --version``'s kernel lines (``  name: status``), summed up: how many are
    "compiled", and the others with their status."""
    try:
        out = subprocess.run([str(python), "-m", "uvnav_tui.cli.main", "--version"], cwd=tree,
                             capture_output=True, text=True, timeout=120).stdout
    except (OSError, subprocess.SubprocessError) as exc:
        return f"uvnav --version failed ({exc})"
    status = re.findall(r"^\s+([\w.]+): (.+)$", out, flags=re.M)
    if not status:
        return " / ".join(out.strip().splitlines()[1:]) or "none listed"
    other = [f"{name} {st}" for name, st in status if st.strip() != "compiled"]
    return (f"{len(status) - len(other)} of {len(status)} compiled"
            + (f"; {'; '.join(other)}" if other else ""))


# ---------------------------------------------------------------- the inputs


def demo_slice(n: int = DEMO_EPOCHS) -> Path:
    """The first ``n`` records of data/DEMO.RUN as their own ``.RUN`` with its config
    (``DEMO<n>.toml``), in the temp folder (written once)."""
    d = Path(tempfile.gettempdir()) / "uvnav-bench-demo-slice"
    d.mkdir(parents=True, exist_ok=True)
    run = d / f"DEMO{n}.RUN"
    if not run.exists():
        lines = (bench_long.DATA / "DEMO.RUN").read_text().splitlines(keepends=True)[:n]
        tmp = run.with_suffix(".tmp")
        tmp.write_text("".join(lines))
        tmp.replace(run)
    run.with_suffix(".toml").write_text(bench_long.config_text(run))
    return run


# ---------------------------------------------------------------- measuring


def _last_error_line(text: str) -> str:
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1][:200] if lines else "no message"


def timed_process(cmd: list[str], cwd: Path, env: dict[str, str],
                  timeout: float = 1800) -> tuple[float, float]:
    """(wall s, CPU s) of the process ``cmd``: wall by ``perf_counter``, CPU (user + system)
    as ``getrusage(RUSAGE_CHILDREN)`` grew around it. Raises RuntimeError with the last line
    of its error output if it exits non-zero."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=cwd, env=env, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True, timeout=timeout)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"exit {done.returncode}: {_last_error_line(done.stderr)}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def measure_once(v: Variant, w: Workload, inputs: dict[str, Path], pycache: Path,
                 out_dir: Path) -> tuple[float, float]:
    """One (wall s, CPU s) of workload ``w`` by variant ``v``; RuntimeError if it fails."""
    if w.key == "paint":
        wall, cpu = bench_startup.first_paint_once(pycache, python=v.python, cwd=v.tree,
                                                   pure=v.pure)
        if wall != wall:  # NaN: the menu bar never appeared
            raise RuntimeError("the menu bar did not appear within 60 s")
        return wall, cpu
    args = ["replay", "data/920917_1.RUN", "--no-out"]
    if w.key in inputs:
        run = inputs[w.key]
        args = ["replay", str(run), "--config", str(run.with_suffix(".toml")),
                "--out", str(out_dir / f"{run.stem}-{v.label.replace(' ', '-')}.OUT"),
                "--force"]
    return timed_process([str(v.python), "-m", "uvnav_tui.cli.main", *args], v.tree,
                         v.env(pycache))


def _attempt(v: Variant, w: Workload, inputs: dict[str, Path], pycache: Path, out_dir: Path,
             timed: bool) -> None:
    """One run of ``w`` by ``v``, kept in ``v.runs`` if ``timed``; a failure goes to
    ``v.failed`` (and that workload is not run again by ``v``)."""
    if w.key in v.failed:
        return
    try:
        r = measure_once(v, w, inputs, pycache, out_dir)
    except RuntimeError as exc:
        v.failed[w.key] = str(exc)
        return
    except subprocess.TimeoutExpired:
        v.failed[w.key] = "timed out"
        return
    if timed:
        v.runs.setdefault(w.key, []).append(r)


def run_rounds(groups: dict[str, list[Variant]], workloads: tuple[Workload, ...],
               inputs: dict[str, Path], pycache: Path, out_dir: Path) -> None:
    """Every workload by every variant, alternating, ``w.rounds`` times (results in the
    variants). First one untimed run of each short workload by each variant (fills the bytecode
    cache, finds a variant that fails); the baseline's pure path is kept only on a Python where
    its compiled path failed, and warmed up then."""
    warm = [w for w in workloads if w.key != "long"]
    for vs in groups.values():
        for v in vs:
            if v.label != BASE_PURE:
                for w in warm:
                    _attempt(v, w, inputs, pycache, out_dir, timed=False)
    for vs in groups.values():
        base, pure = _by(vs, BASE), _by(vs, BASE_PURE)
        if pure is None:
            continue
        if base is not None and not base.failed:
            vs.remove(pure)
            continue
        for w in warm:
            _attempt(pure, w, inputs, pycache, out_dir, timed=False)
    for r in range(max(w.rounds for w in workloads)):
        for w in workloads:
            if r < w.rounds:
                for vs in groups.values():
                    for v in vs:
                        if v.label == BASE_PURE and w.key == "long" and r > 0:
                            continue  # for the record only: one run (~5× the compiled time)
                        _attempt(v, w, inputs, pycache, out_dir, timed=True)
        print(f"  round {r + 1} done, load average {os.getloadavg()[0]:.1f}", flush=True)


# ---------------------------------------------------------------- the table


def _median(runs: list[tuple[float, float]], wall: bool) -> tuple[float, float]:
    """(the figure, the other) medians: (wall, CPU) for a wall workload, else (CPU, wall)."""
    walls = statistics.median(r[0] for r in runs)
    cpus = statistics.median(r[1] for r in runs)
    return (walls, cpus) if wall else (cpus, walls)


def cell(v: Variant | None, w: Workload, note: Callable[[Variant, str], int] | None = None
         ) -> str:
    """A table cell: "0.41 s (wall 0.52)", "fails [1]" (``note`` numbers the error message,
    printed under the table), or "–" (not measured)."""
    if v is None:
        return "–"
    if w.key in v.failed:
        return f"fails [{note(v, v.failed[w.key])}]" if note else "fails"
    runs = v.runs.get(w.key)
    if not runs:
        return "–"
    fig, other = _median(runs, w.wall)
    n_runs = f", {len(runs)} run{'s' * (len(runs) > 1)}" if len(runs) != w.rounds else ""
    return f"{fig:.3f} s ({'CPU' if w.wall else 'wall'} {other:.2f}{n_runs})"


def _figure(v: Variant | None, w: Workload) -> float | None:
    if v is None or w.key in v.failed or not v.runs.get(w.key):
        return None
    return _median(v.runs[w.key], w.wall)[0]


def ratio_cell(this: Variant | None, base: Variant | None, w: Workload,
               fallback: Variant | None = None, fallback_name: str = "") -> str:
    """``this / base`` of the medians; where ``base`` failed, against ``fallback`` (named)."""
    t = _figure(this, w)
    if t is None:
        return "–"
    b = _figure(base, w)
    if b is not None:
        return f"{t / b:.2f}"
    f = _figure(fallback, w)
    if f is not None:
        return f"{t / f:.2f} (vs {fallback_name})"
    return "–"


def table(groups: dict[str, list[Variant]], workloads: tuple[Workload, ...],
          baseline: str = BASELINE) -> str:
    """The Markdown table: per workload and Python, the baseline's figure (its pure path's
    beside where its compiled path fails), this tree's, and the ratio this / baseline; under
    it, each distinct failure's message, numbered."""
    rows = [f"| workload | Python | {baseline} | this tree | this tree / {baseline} | target |",
            "|---|---|---|---|---|---|"]
    notes: dict[str, int] = {}
    names = {BASE: f"{baseline} compiled", BASE_PURE: f"{baseline} pure", THIS: THIS}
    first = next(iter(groups), None)
    ref_base = _by(groups.get(first, []), BASE) if first else None
    for w in workloads:
        for ver, vs in groups.items():
            def note(v: Variant, msg: str, ver: str = ver) -> int:
                text = f"{names.get(v.label, v.label)} on Python {ver}: {msg}"
                return notes.setdefault(text, len(notes) + 1)

            base, pure, this = _by(vs, BASE), _by(vs, BASE_PURE), _by(vs, THIS)
            bcell = cell(base, w, note)
            if base is not None and w.key in base.failed and pure is not None:
                bcell = f"compiled {bcell}; pure: {cell(pure, w, note)}"
            fallback = ref_base if ver != first else None
            rows.append(f"| {w.name} | {ver} | {bcell} | {cell(this, w, note)} | "
                        f"{ratio_cell(this, base, w, fallback, f'{baseline} on {first}')} | "
                        f"{w.target} |")
    if notes:
        rows += ["", *(f"* [{n}] {text}" for text, n in notes.items())]
    return "\n".join(rows)


def _by(vs: list[Variant], label: str) -> Variant | None:
    return next((v for v in vs if v.label == label), None)


def replace_doc_section(text: str, section: str) -> str:
    """``text`` with what lies between :data:`DOC_BEGIN` and :data:`DOC_END` replaced by
    ``section``; ValueError if the markers are missing or out of order."""
    i, j = text.find(DOC_BEGIN), text.find(DOC_END)
    if i < 0 or j < 0 or j < i:
        raise ValueError(f"markers {DOC_BEGIN} … {DOC_END} not found in order")
    return text[:i + len(DOC_BEGIN)] + "\n" + section.strip() + "\n" + text[j:]


def conditions(rounds: str, load_start: float, load_end: float) -> str:
    """The conditions line printed above the table."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            m = re.search(r"model name\s*:\s*(.+)", f.read())
            if m:
                model = m.group(1).strip()
    except OSError:
        pass
    return (f"{model}, {os.cpu_count()} CPU(s), {platform.system()} {platform.release()}; "
            f"load average {load_start:.1f} at the start, {load_end:.1f} at the end; "
            f"{rounds}; OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")


# ---------------------------------------------------------------- main


def prepare(commit: str | None, skip_notes: list[str]) -> dict[str, list[Variant]]:
    """The variants per Python (``x.y.z`` keys), in the order of :func:`pythons`; what cannot
    be prepared goes to ``skip_notes``."""
    groups: dict[str, list[Variant]] = {}
    found = pythons()
    if len(found) < 2:
        skip_notes.append(f"no Python newer than {_minor(found[0][0])} found (pyenv or PATH, "
                          ".ci/newest-python): measured on that one only")
    for version, base_py in found:
        vs: list[Variant] = []
        try:
            this_py: Path | None = this_tree_python(version)
            vs.append(Variant(THIS, this_py, ROOT))  # type: ignore[arg-type]
        except Unavailable as exc:
            this_py = None
            skip_notes.append(f"this tree on Python {version}: skipped, {exc}")
        if commit is not None:
            try:
                py, note = baseline_python(commit, version, base_py, constraints(this_py))
                src = baseline_source(commit)
                vs.insert(0, Variant(BASE, py, src))
                skip_notes.append(f"{BASELINE} on Python {version}: {note}; kernels: "
                                  f"{kernels_line(py, src)}")
                vs.insert(1, Variant(BASE_PURE, py, src, pure=True))
            except Unavailable as exc:
                skip_notes.append(f"{BASELINE} on Python {version}: skipped, {exc}")
        if this_py is not None:
            skip_notes.append(f"this tree on Python {version}: kernels: "
                              f"{kernels_line(this_py, ROOT)}")
        if vs:
            groups[version] = vs
    return groups


def main() -> None:
    """Prepare the trees, run the rounds, print the conditions and the Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--doc", type=Path, help="also write the table into this Markdown "
                        f"file between {DOC_BEGIN} and {DOC_END}")
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--long-rounds", type=int, default=LONG_ROUNDS)
    args, _rest = parser.parse_known_args()
    t_start = time.perf_counter()
    load_start = os.getloadavg()[0]
    print(f"This tree against the baseline {BASELINE}, per Python: `uvnav` in fresh processes")
    notes: list[str] = []
    try:
        commit: str | None = baseline_commit()
    except Unavailable as exc:
        commit = None
        notes.append(f"{BASELINE}: skipped, {exc}")
    groups = prepare(commit, notes)
    workloads = tuple(
        Workload(w.key, w.name, w.target,
                 args.long_rounds if w.key == "long" else args.rounds, w.wall)
        for w in WORKLOADS if w.key != "paint" or shutil.which("tmux"))
    if len(workloads) < len(WORKLOADS):
        notes.append("first paint: skipped, tmux not found")
    inputs = {"demo": demo_slice(),
              "long": bench_long.first_hours(
                  bench_long.simulated_mission(bench_long.scenario_text()), 24)}
    t_prep = time.perf_counter() - t_start
    with tempfile.TemporaryDirectory(prefix="uvnav-bench-baseline-run-") as tmp:
        paint = any(w.key == "paint" for w in workloads)
        if paint:  # the tmux server, started once so its start is not timed
            bench_startup._tmux("new-session", "-d", "-s", "keep", "sleep 3600")
        try:
            run_rounds(groups, workloads, inputs, Path(tmp) / "pycache", Path(tmp))
        finally:
            if paint:
                bench_startup._tmux("kill-server", check=False)
    rounds = (f"medians of {args.rounds} alternating rounds ({args.long_rounds} for the 24 h "
              "mission); replays: CPU time of the process, first paint: wall time")
    print(conditions(rounds, load_start, os.getloadavg()[0]))
    for n in notes:
        print(f"  {n}")
    section = "\n".join([conditions(rounds, load_start, os.getloadavg()[0]) + ".", "",
                         table(groups, workloads)])
    print()
    print(table(groups, workloads))
    print(f"\n  preparation {t_prep:.0f} s, measuring {time.perf_counter() - t_start - t_prep:.0f}"
          " s (wall)")
    if args.doc is not None:
        args.doc.write_text(replace_doc_section(args.doc.read_text(), section))
        print(f"  table written into {args.doc}")


if __name__ == "__main__":
    main()
