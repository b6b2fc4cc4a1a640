"""The campaign spec (engine/campaign/spec.py): located errors, seeds, run keys; and that the
console and ``uvnav replay`` never import Dask (docs/CAMPAIGN.md)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from engine.campaign.spec import load_campaign, parse_seeds
from engine.errors import InputError
from tests.paths import DATA, ROOT

SHORT = DATA / "campaigns" / "scenarios" / "SHORT_DIVE.scenario.toml"


def _spec(tmp_path: Path, body: str, name: str = "c.toml") -> Path:
    p = tmp_path / name
    p.write_text(body, encoding="utf-8")
    return p


def _error(path: Path) -> InputError:
    with pytest.raises(InputError) as info:
        load_campaign(path)
    return info.value


def test_runs_are_scenarios_times_variants_times_seeds(tmp_path: Path) -> None:
    p = _spec(tmp_path, f'scenarios = ["{SHORT}"]\nseeds = "3-5,9"\n'
              '[[variants]]\nname = "a"\n[[variants]]\nname = "b"\n'
              'filter = { preset = "thesis" }\n')
    spec = load_campaign(p)
    assert [(t.variant, t.seed) for t in spec.tasks] == [
        ("a", 3), ("a", 4), ("a", 5), ("a", 9), ("b", 3), ("b", 4), ("b", 5), ("b", 9)]
    assert len({t.key for t in spec.tasks}) == 8
    assert spec.variants[1].overrides == {"filter": {"preset": "thesis"}}
    # the same inputs give the same keys; another seed list another spec hash
    again = load_campaign(p)
    assert [t.key for t in again.tasks] == [t.key for t in spec.tasks]
    p2 = _spec(tmp_path, p.read_text().replace('"3-5,9"', '"3-5"'), "c2.toml")
    other = load_campaign(p2)
    assert other.spec_hash != spec.spec_hash
    assert [t.key for t in other.tasks] == [t.key for t in spec.tasks if t.seed != 9]


def test_a_changed_scenario_changes_the_keys(tmp_path: Path) -> None:
    for name in ("SHORT_DIVE.scenario.toml", "SHORT_DIVE.toml"):
        (tmp_path / name).write_text((SHORT.parent / name).read_text().replace(
            'data_dir = "../.."', f'data_dir = "{DATA}"'), encoding="utf-8")
    p = _spec(tmp_path, 'scenarios = ["SHORT_DIVE.scenario.toml"]\nseeds = [1]\n')
    before = load_campaign(p).tasks[0].key
    scen = tmp_path / "SHORT_DIVE.scenario.toml"
    scen.write_text(scen.read_text().replace("speed_kn = 10.0", "speed_kn = 9.0"))
    assert load_campaign(p).tasks[0].key != before


@pytest.mark.parametrize("text, expected", [
    ("1-3", (1, 2, 3)), ("7", (7,)), ("1-2, 5", (1, 2, 5)), ([0, 4], (0, 4))])
def test_seeds(text: object, expected: tuple[int, ...]) -> None:
    assert parse_seeds(text) == expected


@pytest.mark.parametrize("body, line, field, words", [
    (f'scenarios = ["{SHORT}"]\nseeds = "1-3"\nworkers = 4\n', 3, "workers", "Unknown key"),
    (f'scenarios = ["{SHORT}"]\nseeds = "5-1"\n', 2, "seeds", "end is below the start"),
    (f'scenarios = ["{SHORT}"]\nseeds = "1-x"\n', 2, "seeds", "Bad seed range"),
    (f'scenarios = ["{SHORT}"]\nseeds = [1, 1]\n', 2, "seeds", "twice"),
    (f'scenarios = ["{SHORT}"]\nseeds = "1-2000000"\n', 2, "seeds", "Too many"),
    # a duplicate at the end of a long list (found in one pass: a quadratic search hung)
    (f'scenarios = ["{SHORT}"]\nseeds = "1-400000,400000"\n', 2, "seeds", "twice"),
    ('scenarios = [\n  "nowhere/X.scenario.toml",\n]\nseeds = "1"\n', 2, "scenarios",
     "not found"),
    (f'scenarios = ["{SHORT}"]\nseeds = "1"\n[config]\nfilter = {{ presett = "thesis" }}\n', 4,
     "config.filter.presett", "Unknown key"),
    (f'scenarios = ["{SHORT}"]\nseeds = "1"\n[[variants]]\nname = "x"\n'
     'lsq = { gps_se_sf = -1 }\n', 5, "variants[1].lsq.gps_se_sf", ""),
    (f'scenarios = ["{SHORT}"]\nseeds = "1"\n[config]\nrun_file = "x.RUN"\n', 4,
     "config.run_file", "Set by the campaign"),
])
def test_spec_errors_are_located(tmp_path: Path, body: str, line: int, field: str,
                                 words: str) -> None:
    p = _spec(tmp_path, body)
    err = _error(p)
    assert (err.file, err.line, err.field) == (str(p), line, field), str(err)
    assert words in err.message


def test_an_error_in_a_scenario_names_the_scenario_file(tmp_path: Path) -> None:
    scen = tmp_path / "BAD.scenario.toml"
    scen.write_text(SHORT.read_text().replace('data_dir = "../.."', f'data_dir = "{DATA}"')
                    .replace("speed_kn = 10.0", "speed_kn = -3.0"), encoding="utf-8")
    (tmp_path / "BAD.toml").write_text((SHORT.parent / "SHORT_DIVE.toml").read_text().replace(
        'data_dir = "../.."', f'data_dir = "{DATA}"'), encoding="utf-8")
    err = _error(_spec(tmp_path, 'scenarios = ["BAD.scenario.toml"]\nseeds = "1"\n'))
    assert err.file == str(scen) and err.line is not None and "speed_kn" in (err.field or "")


def test_console_and_replay_do_not_import_dask() -> None:
    """Dask and pyarrow are loaded by ``uvnav campaign`` only (start-up time of the others)."""
    code = ("import sys\n"
            "import uvnav_tui.cli.main, uvnav_tui.cli.replay, uvnav_tui.cli.console, "
            "uvnav_tui.app, engine.api, engine.campaign\n"
            "import engine.api as api\n"
            "api.load_campaign; api.run_one\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('dask', 'distributed', 'pyarrow')))\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, timeout=120, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_a_scenario_with_its_configuration_named(tmp_path: Path) -> None:
    """``{ scenario = ..., config = ... }``: the configuration need not sit beside it; the
    label is the scenario's; the run key is that of the same two files named the short way."""
    cfg = SHORT.parent / "SHORT_DIVE.toml"
    p = _spec(tmp_path, f'scenarios = [{{ scenario = "{SHORT}", config = "{cfg}" }}]\n'
              'seeds = "1"\n')
    spec = load_campaign(p)
    short = load_campaign(_spec(tmp_path, f'scenarios = ["{SHORT}"]\nseeds = "1"\n', "s.toml"))
    assert spec.tasks[0].scenario == "SHORT_DIVE"
    assert spec.tasks[0].key == short.tasks[0].key
    bad = _spec(tmp_path, f'scenarios = [{{ scenario = "{SHORT}", confg = "{cfg}" }}]\n'
                'seeds = "1"\n', "b.toml")
    err = _error(bad)
    assert (err.line, err.field) == (1, "scenarios[1].confg"), str(err)
