"""The campaign spec (TOML, docs/CAMPAIGN.md) → the runs of a campaign and what a worker needs.

A spec names ``scenarios`` (paths relative to the spec: ``NAME.scenario.toml`` with its start-up
configuration ``NAME.toml`` beside it, or ``{ scenario = "...", config = "..." }``), ``seeds`` (a
list of whole numbers ≥ 0, or a string of ranges ``"1-200"`` / ``"1-5,8,10-12"``), an optional
``[config]`` table of run-configuration overrides applied to every run (docs/CONFIG.md keys,
merged key by key into each scenario's configuration) and optional ``[[variants]]`` tables (a
``name`` plus overrides on top of ``[config]``). An optional ``[sampler]`` table adds the
randomized missions of :mod:`engine.sim.sampler` as one more scenario (its ``name``, default
``random``): each seed draws its own mission, which the worker simulates with that seed.
Runs: every scenario × variant × seed.

Everything a worker needs is shipped with the task (:class:`CampaignBundle`: the scenario and
configuration texts and the bytes of the data files ``TO_WGS84.DAT`` and ``DECCA.CHN``), so a
worker on another machine needs no shared file system. A run's key is a hash of exactly those
inputs plus the overrides, the variant's name and the seed: the same run on any worker, in any
order, has the same key; editing a scenario changes the keys of its runs.

Every error is an :class:`~engine.errors.InputError` located in the spec (file, line, field) or
in the scenario/configuration file it names, raised before any run starts.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import json
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from engine.errors import InputError
from engine.io.tomlsource import (
    UNKNOWN_KEY_MESSAGE,
    SourceIndex,
    parse_located,
    read_text,
)
from engine.run.config import config_from_data, parse_config_text
from engine.run.setup import CHAIN_FILE, DATUM_FILE, read_data_dir
from engine.sim.sampler import SamplerError, SamplerOptions, draw_mission
from engine.sim.scenario import parse_scenario_text
from engine.sim.simulate import read_data_files

__all__ = [
    "DEFAULT_VARIANT",
    "MAX_RUNS",
    "CampaignBundle",
    "CampaignSpec",
    "RunTask",
    "ScenarioInputs",
    "Variant",
    "load_campaign",
    "merge_overrides",
    "parse_seeds",
]

KEY_VERSION = 2
"""Part of every run key: raised when a run's row changes meaning, so old rows are not reused."""
DEFAULT_VARIANT = "default"
"""The one variant of a spec without ``[[variants]]``: no overrides beyond ``[config]``."""
MAX_RUNS = 1_000_000
"""Most runs one spec may ask for (a typo such as ``"1-1000000000"`` is refused, not queued):
the client keeps each run's identity and key, about 0.4 KB a run."""
TOP_KEYS = ("name", "scenarios", "seeds", "config", "variants", "tracks", "sampler")
SAMPLER_KEYS = ("name", "data_dir", "sample_interval_s", "max_mission_s")
SAMPLER_DEFAULT_NAME = "random"
SCENARIO_KEYS = ("scenario", "config")
SCENARIO_SUFFIX = ".scenario.toml"


def _sha(data: bytes | str) -> str:
    return hashlib.sha256(data.encode("utf-8") if isinstance(data, str) else data).hexdigest()


@dataclass(frozen=True)
class ScenarioInputs:
    """One scenario of the spec as shipped to workers: its label (the ``scenario`` column), the
    file names (for messages) and texts of the scenario and its configuration, and the data files
    (name → bytes) of the scenario's and of the configuration's ``data_dir``."""

    label: str
    scenario_file: str
    scenario_text: str
    config_file: str
    config_text: str
    sim_data: tuple[tuple[str, bytes], ...]
    run_data: tuple[tuple[str, bytes], ...]
    sampler: SamplerOptions | None = None

    @functools.cached_property
    def digest(self) -> str:
        """Hash of every input of this scenario (texts and data files; for the sampler its
        version and options, not the texts of the one draw kept for checks)."""
        if self.sampler is not None:
            parts = [self.sampler.digest_text()]
        else:
            parts = [_sha(self.scenario_text), _sha(self.config_text)]
        parts += [f"{n}:{_sha(b)}" for n, b in (*self.sim_data, *self.run_data)]
        return _sha("\n".join(parts))


@dataclass(frozen=True)
class Variant:
    """A configuration variant: its name and the overrides (``[config]`` merged with the
    variant's own keys) as a nested mapping of run-configuration keys."""

    name: str
    overrides: Mapping[str, Any]


@dataclass(frozen=True, order=True)
class RunTask:
    """One run: scenario label, variant name, seed and its key (hash of its inputs)."""

    scenario: str
    variant: str
    seed: int
    key: str


@dataclass(frozen=True)
class CampaignBundle:
    """What every worker gets once (scattered): scenarios and variants by name."""

    scenarios: Mapping[str, ScenarioInputs]
    variants: Mapping[str, Variant]
    tracks: bool = False


@dataclass(frozen=True)
class CampaignSpec:
    """A parsed, checked spec: its path, name, scenarios, variants, seeds, whether each run's
    ``.OUT`` is kept (``tracks``), and the hash of the whole campaign (:attr:`spec_hash`)."""

    path: str
    name: str
    scenarios: tuple[ScenarioInputs, ...]
    variants: tuple[Variant, ...]
    seeds: tuple[int, ...]
    tracks: bool = False
    tasks: tuple[RunTask, ...] = field(default=(), repr=False)

    @property
    def spec_hash(self) -> str:
        """Hash of every run's key and the output options: a spec changed in anything that
        changes a run, or the set of runs, has another hash."""
        return _sha(json.dumps({"keys": [t.key for t in self.tasks], "tracks": self.tracks}))

    def bundle(self) -> CampaignBundle:
        """The inputs every run needs (docs/CAMPAIGN.md, "Where workers find the data")."""
        return CampaignBundle({s.label: s for s in self.scenarios},
                              {v.name: v for v in self.variants}, self.tracks)


def merge_overrides(base: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` (a parsed configuration) with ``overrides`` merged key by key (tables
    recursively; a value replaces a value). Neither argument is changed."""
    out = copy.deepcopy(dict(base))
    for k, v in overrides.items():
        if isinstance(v, Mapping) and isinstance(out.get(k), Mapping):
            out[k] = merge_overrides(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def run_key(scenario: ScenarioInputs, variant: Variant, seed: int) -> str:
    """The key of one run: a hash of its inputs (20 hex digits)."""
    payload = json.dumps({"v": KEY_VERSION, "scenario": scenario.digest,
                          "overrides": variant.overrides, "variant": variant.name,
                          "seed": seed}, sort_keys=True, default=str)
    return _sha(payload)[:20]


def parse_seeds(value: Any, field: str = "seeds") -> tuple[int, ...]:
    """Seeds from a list of whole numbers ≥ 0 or a string of ranges (``"1-200"``,
    ``"1-5,8"``), in the order given, each once (InputError naming the bad part)."""
    seeds: list[int] = []
    if isinstance(value, str):
        for part in value.split(","):
            text = part.strip()
            lo_text, dash, hi_text = text.partition("-")
            if not (lo_text.strip().isdigit() and (not dash or hi_text.strip().isdigit())):
                raise InputError("Bad seed range: whole numbers >= 0 as 'A-B' or 'A' expected !",
                                 field=field, text=text)
            lo = int(lo_text)
            hi = int(hi_text) if dash else lo
            if hi < lo:
                raise InputError("Bad seed range: the end is below the start !", field=field,
                                 text=text)
            if hi - lo + 1 > MAX_RUNS:
                raise InputError(f"Too many seeds (more than {MAX_RUNS}) !", field=field,
                                 text=text)
            seeds.extend(range(lo, hi + 1))
    elif isinstance(value, list):
        for v in value:
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise InputError("Seeds must be whole numbers >= 0 !", field=field, text=str(v))
            seeds.append(v)
    else:
        raise InputError("Seeds must be a list of whole numbers or a range such as '1-200' !",
                         field=field, text=str(value))
    if not seeds:
        raise InputError("No seeds !", field=field)
    seen: set[int] = set()
    for s in seeds:
        if s in seen:
            raise InputError("Seed listed twice !", field=field, text=str(s))
        seen.add(s)
    return tuple(seeds)


def _data_files(data_dir: Path, where: str) -> tuple[tuple[str, bytes], ...]:
    out = []
    for name in (DATUM_FILE, CHAIN_FILE):
        try:
            out.append((name, (data_dir / name).read_bytes()))
        except OSError as exc:
            raise InputError(f"Cannot read the data file ({exc.strerror or exc}) for {where} !",
                             file=str(data_dir / name)) from None
    return tuple(out)


@dataclass
class _Entry:
    scenario: Path
    config: Path
    text: str  # the entry as written (to find its line)


def _entry(value: Any, i: int, base: Path) -> _Entry:
    fld = f"scenarios[{i}]"
    if isinstance(value, str):
        if not value.endswith(SCENARIO_SUFFIX):
            raise InputError(f"A scenario path must end in {SCENARIO_SUFFIX} (its configuration "
                             "NAME.toml beside it), or give { scenario = ..., config = ... } !",
                             field=fld, text=value)
        scen = base / value
        return _Entry(scen, scen.with_name(scen.name[: -len(SCENARIO_SUFFIX)] + ".toml"), value)
    if isinstance(value, dict):
        for k in value:
            if k not in SCENARIO_KEYS:
                raise InputError(UNKNOWN_KEY_MESSAGE, field=f"{fld}.{k}", text=k)
        scen_t, cfg_t = value.get("scenario"), value.get("config")
        if not isinstance(scen_t, str) or not isinstance(cfg_t, str):
            raise InputError("A scenario table needs scenario = \"...\" and config = \"...\" !",
                             field=fld, text=str(value))
        return _Entry(base / scen_t, base / cfg_t, scen_t)
    raise InputError("A scenario is a path or a { scenario, config } table !", field=fld,
                     text=str(value))


def _label(scenario: Path) -> str:
    name = scenario.name
    return name[: -len(SCENARIO_SUFFIX)] if name.endswith(SCENARIO_SUFFIX) else scenario.stem


def _overrides(value: Any, fld: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise InputError("Must be a table of run-configuration keys !", field=fld,
                         text=str(value))
    for k in ("run_file", "data_dir"):
        if k in value:
            raise InputError("Set by the campaign for each run, not in a spec !",
                             field=f"{fld}.{k}", text=k)
    return value


@dataclass
class _Raw:
    """The spec's top level, type-checked (before files are read)."""

    name: str
    entries: list[_Entry]
    seeds: tuple[int, ...]
    config: dict[str, Any]
    variants: list[tuple[str, dict[str, Any]]]
    tracks: bool
    sampler: dict[str, Any] | None = None


def _parse_top(data: Mapping[str, Any], base: Path, default_name: str) -> _Raw:
    for k in data:
        if k not in TOP_KEYS:
            raise InputError(UNKNOWN_KEY_MESSAGE, field=k, text=k)
    name = data.get("name", default_name)
    if not isinstance(name, str) or not name.strip():
        raise InputError("Must be a non-empty string !", field="name", text=str(name))
    sampler = data.get("sampler")
    if sampler is not None:
        if not isinstance(sampler, dict):
            raise InputError("Use a [sampler] table !", field="sampler", text=str(sampler))
        for k in sampler:
            if k not in SAMPLER_KEYS:
                raise InputError(UNKNOWN_KEY_MESSAGE, field=f"sampler.{k}", text=k)
    scen = data.get("scenarios", [] if sampler is not None else None)
    if not isinstance(scen, list) or (not scen and sampler is None):
        raise InputError("scenarios = [\"NAME.scenario.toml\", ...] expected !",
                         field="scenarios", text=None if scen is None else str(scen))
    entries = [_entry(v, i + 1, base) for i, v in enumerate(scen)]
    if "seeds" not in data:
        raise InputError("seeds = \"1-10\" or [1, 2, ...] expected !", field="seeds")
    seeds = parse_seeds(data["seeds"])
    config = _overrides(data.get("config", {}), "config")
    variants: list[tuple[str, dict[str, Any]]] = []
    raw_variants = data.get("variants", [])
    if not isinstance(raw_variants, list):
        raise InputError("Use [[variants]] tables !", field="variants")
    for i, v in enumerate(raw_variants, start=1):
        fld = f"variants[{i}]"
        if not isinstance(v, dict):
            raise InputError("Use [[variants]] tables !", field=fld)
        vname = v.get("name")
        if not isinstance(vname, str) or not vname.strip():
            raise InputError("Each variant needs a name !", field=f"{fld}.name",
                             text=None if vname is None else str(vname))
        if any(vname == n for n, _ in variants):
            raise InputError("Variant name used twice !", field=f"{fld}.name", text=vname)
        variants.append((vname, _overrides({k: x for k, x in v.items() if k != "name"}, fld)))
    if not variants:
        variants = [(DEFAULT_VARIANT, {})]
    tracks = data.get("tracks", False)
    if not isinstance(tracks, bool):
        raise InputError("Must be true or false !", field="tracks", text=str(tracks))
    n = (len(entries) + (sampler is not None)) * len(variants) * len(seeds)
    if n > MAX_RUNS:
        raise InputError(f"Too many runs ({n}, at most {MAX_RUNS}) !", field="seeds")
    return _Raw(name.strip(), entries, seeds, config, variants, tracks, sampler)


def _sampler_inputs(table: Mapping[str, Any], base: Path, spec_file: str) -> ScenarioInputs:
    """The ``[sampler]`` table as one scenario of the campaign (InputError naming the key)."""
    name = table.get("name", SAMPLER_DEFAULT_NAME)
    if not isinstance(name, str) or not name.strip():
        raise InputError("Must be a non-empty string !", field="sampler.name", text=str(name))
    data_text = table.get("data_dir", "..")
    if not isinstance(data_text, str) or not data_text.strip() or "\0" in data_text:
        raise InputError("A directory name expected !", field="sampler.data_dir",
                         text=str(data_text))
    ints: dict[str, int] = {}
    defaults = SamplerOptions()
    for key, lo, hi in (("sample_interval_s", 1, 60), ("max_mission_s", 60, 43200)):
        v = table.get(key, getattr(defaults, key))
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise InputError(f"A whole number {lo}-{hi} expected !", field=f"sampler.{key}",
                             text=str(v))
        ints[key] = v
    opts = SamplerOptions(ints["sample_interval_s"], ints["max_mission_s"], ".")
    data_dir = base / data_text
    datums, chains = read_data_files(data_dir)
    try:
        first = draw_mission(0, datums, chains, opts)
    except SamplerError as err:
        raise InputError(str(err), field="sampler") from None
    files = _data_files(data_dir, f"[sampler] of {spec_file}")
    return ScenarioInputs(label=name.strip(), scenario_file=f"{name.strip()}.scenario.toml",
                          scenario_text=first.scenario_text,
                          config_file=f"{name.strip()}.toml", config_text=first.config_text,
                          sim_data=files, run_data=files, sampler=opts)


def _entry_line(index: SourceIndex, entry: _Entry) -> int | None:
    """The spec line that names ``entry`` (the first line quoting its text)."""
    for number, line in enumerate(index.lines, start=1):
        if f'"{entry.text}"' in line or f"'{entry.text}'" in line:
            return number
    found = index.where.get("scenarios")
    return None if found is None else found[0]


def _array_line(index: SourceIndex, key: str, text: str | None) -> int | None:
    """The line of an entry of the array ``key`` (its entries are not indexed): the first line
    from the key's own that holds ``text``, else the key's line."""
    found = index.where.get(key)
    if found is None:
        return None
    start = found[0]
    if text:
        for number in range(start, len(index.lines) + 1):
            if text in index.lines[number - 1]:
                return number
    return start


def _load_scenario(entry: _Entry, spec_file: str, line: int | None) -> ScenarioInputs:
    """Read and check one scenario and its configuration (errors located in those files; a
    missing file is located at the spec's line that names it)."""
    for p, what in ((entry.scenario, "scenario"), (entry.config, "configuration")):
        if not p.is_file():
            problem = "is not a file" if p.exists() else "is not found"
            raise InputError(f"The {what} {p} {problem} !", file=spec_file, line=line,
                             field="scenarios", text=entry.text)
    scen_text = read_text(entry.scenario)
    cfg_text = read_text(entry.config)
    scenario = parse_scenario_text(scen_text, str(entry.scenario), entry.scenario.parent)
    sim_datums, sim_chains = read_data_dir(scenario.data_dir)
    parse_scenario_text(scen_text, str(entry.scenario), entry.scenario.parent,
                        known_datums=sim_datums.datums, known_chains=sim_chains)
    cfg = parse_config_text(cfg_text, str(entry.config), entry.config.parent)
    run_datums, run_chains = read_data_dir(cfg.data_dir)
    parse_config_text(cfg_text, str(entry.config), entry.config.parent,
                      known_datums=run_datums.datums, known_chains=run_chains)
    return ScenarioInputs(
        label=_label(entry.scenario), scenario_file=str(entry.scenario),
        scenario_text=scen_text, config_file=str(entry.config), config_text=cfg_text,
        sim_data=_data_files(scenario.data_dir, str(entry.scenario)),
        run_data=_data_files(cfg.data_dir, str(entry.config)),
    )


def check_overrides(scenario: ScenarioInputs, overrides: Mapping[str, Any], fld: str) -> None:
    """Apply ``overrides`` to the scenario's configuration and check the result as a
    configuration file is checked (InputError with the field under ``fld``)."""
    base = tomllib.loads(scenario.config_text)
    data = merge_overrides(base, overrides)
    data.pop("data_dir", None)
    data["run_file"] = "campaign.RUN"
    try:
        config_from_data(data)
    except InputError as err:
        name = err.field or ""
        top = name.split(".")[0]
        if top in overrides:
            raise InputError(err.message, field=f"{fld}.{name}", text=err.text) from None
        raise InputError(f"{err.message} (with the campaign's overrides)",
                         file=scenario.config_file, field=name, text=err.text) from None


def load_campaign(path: str | os.PathLike[str]) -> CampaignSpec:
    """Read and check a campaign spec and every scenario, configuration and data file it names
    (InputError, located, for anything wrong: before any run starts)."""
    file = Path(path)
    spec_file = str(file)
    text = read_text(file)
    index = SourceIndex(text, unquote=True)
    data = parse_located(text, spec_file, lambda d: d, unquote=True)
    try:
        raw = _parse_top(data, file.parent, file.name.removesuffix(".toml"))
    except InputError as err:
        located = index.locate(err, spec_file)
        if located.line is None and (err.field or "").startswith("scenarios["):
            located = located.located(line=_array_line(index, "scenarios", err.text))
        raise located from None
    scenarios: list[ScenarioInputs] = []
    if raw.sampler is not None:
        try:
            scenarios.append(_sampler_inputs(raw.sampler, file.parent, spec_file))
        except InputError as err:
            raise (index.locate(err, spec_file) if err.file is None else err) from None
    for entry in raw.entries:
        inputs = _load_scenario(entry, spec_file, _entry_line(index, entry))
        if any(s.label == inputs.label for s in scenarios):
            raise InputError("Scenario listed twice !", file=spec_file,
                             line=_entry_line(index, entry), field="scenarios", text=entry.text)
        scenarios.append(inputs)
    variants = []
    for i, (vname, own) in enumerate(raw.variants, start=1):
        merged = merge_overrides(raw.config, own)
        try:
            for s in scenarios:
                check_overrides(s, raw.config, "config")
                if own:
                    check_overrides(s, merged, f"variants[{i}]")
        except InputError as err:
            raise (index.locate(err, spec_file) if err.file is None else err) from None
        variants.append(Variant(vname, merged))
    tasks = tuple(RunTask(s.label, v.name, seed, run_key(s, v, seed))
                  for s in scenarios for v in variants for seed in raw.seeds)
    return CampaignSpec(spec_file, raw.name, tuple(scenarios), tuple(variants), raw.seeds,
                        raw.tracks, tasks)
