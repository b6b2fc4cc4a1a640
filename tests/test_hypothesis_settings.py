"""Every property test runs with new draws and without timing verdicts (tests/conftest.py).

A property test may fail CI only on a counterexample: never because a loaded machine (CI runs
two suites on two shared cores) made an example exceed a deadline or generation look too slow,
and never with a fixed seed that hides the cases a fresh draw would find.
"""

from __future__ import annotations

import importlib
import sys

from hypothesis import HealthCheck

from tests.paths import ROOT


def _property_tests() -> list[tuple[str, object]]:
    """Every @given test of the suite, from the modules pytest already imported (a full run) or
    imported here (this file alone)."""
    loaded = {getattr(m, "__file__", None): m for m in list(sys.modules.values())}
    found = []
    for path in sorted((ROOT / "tests").rglob("test_*.py")):
        text = path.read_text(encoding="utf-8")
        if "@given" not in text:
            continue
        name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        module = loaded.get(str(path)) or importlib.import_module(name)
        for attr, obj in vars(module).items():
            if getattr(obj, "is_hypothesis_test", False):
                found.append((f"{name}::{attr}", obj))
    return found


def test_every_property_test_has_no_deadline_nor_too_slow_check() -> None:
    tests = _property_tests()
    assert len(tests) >= 80  # the suite's property tests (89 when this was written)
    wrong = []
    for name, fn in tests:
        s = fn._hypothesis_internal_use_settings  # type: ignore[attr-defined]
        if (s.deadline is not None or HealthCheck.too_slow not in s.suppress_health_check
                or s.derandomize or not s.print_blob):
            wrong.append(name)
    assert not wrong, f"timing verdicts or fixed draws in {wrong}"



def test_the_profile_draws_afresh_on_a_ci_machine_too() -> None:
    """With ``CI`` set, Hypothesis loads its own ``ci`` profile (fixed draws) before ours; the
    suite's profile must still draw new examples there (a subprocess, so the variable is set
    before Hypothesis is imported)."""
    import os
    import subprocess

    code = ("import tests.conftest\nfrom hypothesis import settings\n"
            "print(settings.default.derandomize, settings.default.deadline)")
    env = {**os.environ, "CI": "true"}
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, check=True,
                         capture_output=True, text=True).stdout.split()
    assert out == ["False", "None"]
