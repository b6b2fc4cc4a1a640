"""What the console's screens and menu actions may ask of the application.

A :class:`typing.Protocol`, implemented by :class:`uvnav_tui.app.UVNAVApp`: the screens and
:mod:`uvnav_tui.actions` depend on this small surface instead of importing the app, so the app
can import them without an import cycle.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from textual.screen import Screen

from engine.api import DatumFile, DeccaChain, RunConfig
from uvnav_tui.run_control import RunController
from uvnav_tui.widgets.message_log import MessageLog


class ConsoleHost(Protocol):
    """The running console, as seen by its screens and menu actions."""

    dev_mode: bool
    """Developer menus and pages shown (A4)."""
    launch_dev_mode: bool
    """The mode the console started in (Run ▸ Start returns to it)."""
    page: int
    """The page shown on the console screen (100 = main page)."""
    control: RunController | None
    """The run (None before the first one)."""
    data: tuple[DatumFile, dict[str, DeccaChain]]
    """``TO_WGS84.DAT`` and the Decca chains by name."""
    base_config: RunConfig
    """The start-up configuration (Parameter Initialization starts from it)."""
    message_log: MessageLog
    lop_policy: str
    """``ask``, ``yes`` or ``no``: how an LOP flagged for rejection is answered."""
    hardcopy_dir: Path
    hardcopies: list[tuple[Path, Path]]

    @property
    def config(self) -> RunConfig:
        """The configuration in force."""

    @property
    def datum_names(self) -> list[str]:
        """Datums of ``TO_WGS84.DAT``, in file order."""

    @property
    def screen(self) -> Screen[Any]:
        """The screen on top."""

    def say(self, text: str) -> None:
        """Show a message on the message line (and keep it in the log)."""

    def refresh_display(self) -> None:
        """Repaint from engine state."""

    def kick(self) -> None:
        """Start the cycle worker if the run may advance."""

    def stop_run(self) -> None:
        """End the current run."""

    def start_run(self, cfg: RunConfig) -> str | None:
        """Start a run for ``cfg`` (or return why it cannot be started)."""

    def open_menu(self, index: int, path: list[int] | None = None) -> None:
        """Open pulldown ``index`` of the menu bar."""

    def show_page(self, number: int) -> None:
        """Show page ``number`` (or say why not)."""

    def sub_page(self, step: int) -> None:
        """PgDn (+1) / PgUp (−1) between the sub-pages of the page shown."""

    def do_menu_action(self, action: str) -> None:
        """Run a menu action by id (see :mod:`uvnav_tui.menus`)."""

    def set_interrupted(self, covered: bool) -> None:
        """The console screen was covered (True) or uncovered (False) by another screen."""

    # Textual's App methods the actions use.
    def push_screen(self, screen: Screen[Any], callback: Callable[[Any], Any] | None = None,
                    ) -> Any:
        """Show ``screen`` over the others."""

    def run_worker(self, work: Callable[[], Any], **kwargs: Any) -> Any:
        """Run ``work`` in a worker."""

    def call_after_refresh(self, callback: Callable[..., Any], *args: Any) -> bool:
        """Call ``callback`` after the next refresh."""

    def call_from_thread(self, callback: Callable[..., Any], *args: Any) -> Any:
        """Call ``callback`` in the UI thread."""

    def exit(self, result: Any = None) -> None:
        """Leave the application."""
