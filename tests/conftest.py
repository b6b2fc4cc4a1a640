"""Fixtures shared by the test modules (pytest loads this file first).

Paths (``ROOT``, ``DATA``) and ``copy_data`` live in :mod:`tests.paths`, which test modules
import (they cannot import this file).
"""

from __future__ import annotations

import signal
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from tests.paths import copy_data

# Hypothesis: every run draws new examples (no derandomize: a fresh draw on CI may find a case
# no earlier run met, and that is what the property tests are for), but no verdict on timing.
# CI runs the 3.11 and 3.13 suites on two shared cores: an example slower than the default
# 200-ms deadline, or a slow start of generation (the too_slow health check), says nothing
# about the code under test (performance is measured in bench/, never asserted in tests).
# print_blob: a CI failure prints the @reproduce_failure line that replays it here.
# derandomize=False is explicit: with CI (or another CI variable) set in the environment,
# Hypothesis loads its own "ci" profile first, which fixes the draws, and a profile registered
# without a parent inherits from whatever profile is loaded.
# The profile is the default of every @settings(...) created after this file is imported (the
# test modules, which only set max_examples and sometimes suppress more checks).
settings.register_profile("uvnav", parent=settings.get_profile("default"), derandomize=False,
                          deadline=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("uvnav")


# A test runner started in the background by a non-interactive shell (`cmd &`) inherits SIGINT
# ignored, and so would every uvnav process a test starts: the Ctrl-C tests would then see a run
# finish instead of exit 130. A handled signal is reset to its default in a child at exec, so
# handling SIGINT here gives the children the default a terminal gives them.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture
def data_dir(tmp_path: Path) -> Path:
    """A private copy of the bundled data files (``data/``) in ``tmp_path/data``; a module may
    define its own ``data_dir`` instead."""
    return copy_data(tmp_path / "data")
