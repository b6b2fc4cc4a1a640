"""The 'Parameter Initialization' cadre shown over the main page at start-up (THEORY §12.3).

Asks, in the thesis' order, for the geodetic datum (choices from ``TO_WGS84.DAT``), the initial
DR position, the depth, the current speed and direction (the set) and the run file: the
``.RUN`` file's name without extension (the thesis' field), or the path of any ``.RUN`` file or
NMEA 0183 log (recognised by its content, docs/NMEA.md), absolute, ``~/…`` or relative to the
run directory or the current directory; or a live NMEA source's URL, ``udp://0.0.0.0:10110``
(docs/LIVE.md). Tab completes a path, Ctrl+O opens a file picker. Every field is checked as it is
typed; Return starts the run.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from pathlib import Path

from textual.app import ComposeResult
from textual.binding import Binding
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
from uvnav_tui.dialogs.dialog import NUMBER_HELP, POSITION_HELP, Dialog
from uvnav_tui.keys_help import DIALOG_KEYS
from uvnav_tui.widgets.path_completion import PathSuggester, complete_path, is_path_like
from uvnav_tui.widgets.validated_field import ValidatedField, number_text

NOT_A_RUN_FILE_MESSAGE = "Neither a .RUN file nor an NMEA 0183 log !"
FOLDER_MESSAGE = "A folder, not a file (Ctrl+O: pick a file) !"

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
    KEY_HINTS = (*DIALOG_KEYS[:5], ("Ctrl+O", "Open file"), *DIALOG_KEYS[5:])
    BINDINGS = [Binding("ctrl+o", "pick_file", "Open file", show=False)]
    HELP = f"""
Starts a run. Every field is pre-filled from the configuration; Enter starts the run.

Geodetic datum: the working datum, a name of TO_WGS84.DAT (any case; → completes the \
suggestion, the names that match are listed under the field).
DR position: the dead-reckoning start position on that datum. {POSITION_HELP}
Depth (m): 0 to 1000.   Current speed (kn): 0 to 60.
Current direction (°): the set, towards which the water flows, 0 to 360.
Run file: NAME for NAME.RUN beside the configured run file, or any path to a .RUN file or an \
NMEA 0183 log (absolute, relative to the current directory, or ~/...), or a live source's URL: \
udp://0.0.0.0:10110, tcp://HOST:10110, serial:///dev/ttyUSB0?baud=4800. Ctrl+O opens a file \
picker; Tab in the field completes a path.
{NUMBER_HELP}
"""
    OK_LABEL = "Start"

    def __init__(self, config: RunConfig, datum_names: list[str],
                 start: Callable[[RunConfig], str | None]) -> None:
        super().__init__()
        self.config = config
        self.datum_names = datum_names
        self.start = start
        self.run_dir = config.run_path.parent

    @property
    def search_dirs(self) -> list[Path]:
        """Where a relative run-file path is looked for: the run directory, then the current
        directory."""
        return [self.run_dir, Path.cwd()]

    def _find(self, typed: str) -> Path | None:
        """The typed path (``~`` expanded; a relative one in :attr:`search_dirs`), if it
        exists."""
        path = Path(os.path.expanduser(typed))
        candidates = [path] if path.is_absolute() else [d / path for d in self.search_dirs]
        return next((p for p in candidates if p.exists()), None)

    def _run_name(self, text: str) -> str:
        """The run file: ``NAME.RUN`` for a typed ``NAME`` of the run directory (the thesis'
        field); else the path of a ``.RUN`` file or an NMEA 0183 log (by its content,
        docs/NMEA.md) anywhere — its name alone if it is in the run directory, else its
        absolute path; or a live source's URL (docs/LIVE.md)."""
        if is_source_url(text):  # a live source (docs/LIVE.md)
            return parse_source_url(text).url
        typed = text.strip()
        bare = not is_path_like(typed)
        name_error: InputError | None = None
        if bare:
            try:
                name = parse_run_name(text, field="run file")
            except InputError as exc:
                name, name_error = None, exc
            if name is not None and (self.run_dir / f"{name}.RUN").is_file():
                return f"{name}.RUN"
        path = self._find(typed) if typed else None
        if path is None:
            if name_error is not None and _LOG_NAME_RE.fullmatch(typed) is None:
                raise name_error
            raise InputError(FILE_NOT_FOUND_MESSAGE, field="run file", text=text)
        if path.is_dir():
            raise InputError(FOLDER_MESSAGE, field="run file", text=text)
        if path.suffix.upper() != ".RUN" and not api.is_nmea_file(path):
            raise InputError(NOT_A_RUN_FILE_MESSAGE, field="run file", text=text)
        path = path.resolve()
        return path.name if path.parent == self.run_dir.resolve() else str(path)

    def _complete(self, text: str) -> str | None:
        """Tab in the run-file field: the path completed (None: nothing to add)."""
        return complete_path(text, self.search_dirs)

    def action_pick_file(self) -> None:
        """Ctrl+O: choose the run file in a folder tree (from the folder of what is typed, else
        the run directory); the choice goes into the field."""
        from uvnav_tui.screens.file_picker import FilePicker

        field = self.query_one("#init-run", ValidatedField)
        typed = field.text.strip()
        start = self.run_dir
        if typed and not is_source_url(typed):
            found = self._find(typed)
            if found is not None:
                start = found if found.is_dir() else found.parent

        def chosen(path: Path | None) -> None:
            if path is not None:
                field.input.value = str(path)
                field.input.cursor_position = len(field.input.value)
            field.focus_input()

        self.app.push_screen(FilePicker(start), callback=chosen)

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
        yield ValidatedField("Run file", run_text, self._run_name, id="init-run",
                             suggester=PathSuggester(self.search_dirs),
                             completer=self._complete)

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
