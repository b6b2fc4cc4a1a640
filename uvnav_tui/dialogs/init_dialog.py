"""The 'Parameter Initialization' cadre shown over the main page at start-up (THEORY §12.3).

Asks, in the thesis' order, for the geodetic datum (choices from ``TO_WGS84.DAT``), the initial
DR position, the depth, the current speed and direction (the set) and the ``.RUN`` file name
without extension (or an NMEA 0183 log's file name in full, recognised by its content,
docs/NMEA.md; or a live NMEA source's URL, ``udp://0.0.0.0:10110``, docs/LIVE.md). Every field is
checked as it is typed; Return starts the run.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

from textual.app import ComposeResult
from textual.suggester import SuggestFromList

from engine import api
from engine.api import (
    FILE_NOT_FOUND_MESSAGE,
    InputError,
    RunConfig,
    is_source_url,
    parse_datum_name,
    parse_depth_m,
    parse_direction_deg,
    parse_position,
    parse_run_name,
    parse_source_url,
    parse_speed_kn,
)
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.widgets.validated_field import ValidatedField, number_text

_LOG_NAME_RE = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9_.-]*")
"""A run file named in full in the run directory (an NMEA log): no path, no leading dot."""


def _shown_run_name(run_file: str) -> str:
    """The run file as the field shows it: the name without ``.RUN`` (the thesis' field), an
    NMEA log's name in full."""
    path = Path(run_file)
    return path.stem if path.suffix.upper() in (".RUN", "") else path.name


def datum_hint(names: list[str]) -> Callable[[str], str]:
    """A hint listing the datums that start with what is typed (when it is not one yet)."""

    def hint(text: str) -> str:
        wanted = " ".join(text.split()).upper()
        if any(" ".join(n.split()).upper() == wanted for n in names):
            return ""
        matches = [n for n in names if n.upper().startswith(wanted)] if wanted else names
        if not matches:
            return ""
        return "(" + ", ".join(matches[:6]) + (", …" if len(matches) > 6 else "") + ")"

    return hint


class InitDialog(Dialog[RunConfig]):
    """Dismissed with the run's configuration once the run has been started."""

    CANCEL_IF_UNCHANGED = False

    TITLE = "Parameter Initialization"
    OK_LABEL = "Start"

    def __init__(self, config: RunConfig, datum_names: list[str],
                 start: Callable[[RunConfig], str | None]) -> None:
        super().__init__()
        self.config = config
        self.datum_names = datum_names
        self.start = start
        self.run_dir = config.run_path.parent

    def _run_name(self, text: str) -> str:
        """The run file's name in the run directory: ``NAME.RUN`` for a typed ``NAME`` (the
        thesis' field), or a file named in full that is an NMEA 0183 log by its content
        (docs/NMEA.md), e.g. ``trip.nmea``, or a live source's URL (docs/LIVE.md)."""
        if is_source_url(text):  # a live source (docs/LIVE.md)
            return parse_source_url(text).url
        try:
            name = parse_run_name(text, field="run file")
        except InputError:
            if _LOG_NAME_RE.fullmatch(text.strip()) is None:
                raise
            name = None
        if name is not None and (self.run_dir / f"{name}.RUN").is_file():
            return f"{name}.RUN"
        log = self.run_dir / text.strip()
        if _LOG_NAME_RE.fullmatch(text.strip()) is not None and api.is_nmea_file(log):
            return log.name
        raise InputError(FILE_NOT_FOUND_MESSAGE, field="run file", text=text)

    def compose_body(self) -> ComposeResult:
        """The six start-up questions, pre-filled from the configuration."""
        cfg = self.config
        names = self.datum_names
        yield ValidatedField(
            "Geodetic datum", cfg.datum, lambda t: parse_datum_name(t, names), id="init-datum",
            suggester=SuggestFromList(names, case_sensitive=False), hint=datum_hint(names))
        yield ValidatedField("DR position", cfg.dr_position, parse_position, id="init-dr")
        yield ValidatedField("Depth (m)", number_text(cfg.depth_m), parse_depth_m,
                             id="init-depth")
        yield ValidatedField("Current speed (kn)", number_text(cfg.current_speed_kn),
                             parse_speed_kn, id="init-speed")
        yield ValidatedField("Current direction (°)", number_text(cfg.current_set_deg),
                             parse_direction_deg, id="init-set")
        run_text = (cfg.run_file if is_source_url(cfg.run_file)
                    else _shown_run_name(cfg.run_file))
        yield ValidatedField("Run file (no .RUN)", run_text, self._run_name, id="init-run")

    def on_mount(self) -> None:
        """The cursor starts in the datum field."""
        self.query_one("#init-datum", ValidatedField).focus_input()

    def values(self) -> RunConfig:
        """The configuration with the dialog's values applied (all fields valid); a field left
        as pre-filled keeps the configuration's value exactly."""
        f = {w.id: w for w in self.query(ValidatedField)}
        cfg = self.config
        run = f["init-run"]
        return cfg.replace(
            datum=f["init-datum"].value_or(cfg.datum),
            dr_position=f["init-dr"].text.strip() if f["init-dr"].edited else cfg.dr_position,
            depth_m=f["init-depth"].value_or(cfg.depth_m),
            current_speed_kn=f["init-speed"].value_or(cfg.current_speed_kn),
            current_set_deg=f["init-set"].value_or(cfg.current_set_deg),
            run_file=(cfg.run_file if not run.edited else run.parsed if is_source_url(run.parsed)
                      else str(self.run_dir / run.parsed)),
        )

    def collect(self) -> RunConfig | None:
        """Start the run with the typed values; None (dialog stays) on any error."""
        if self.first_invalid() is not None:
            return None
        try:
            cfg = self.values()
        except InputError as exc:
            self.set_message(exc.message)
            return None
        error = self.start(cfg)
        if error is not None:
            self.set_message(error)
            return None
        return cfg
