"""The file picker of the run-file field (Ctrl+O in Parameter Initialization): Textual's
``DirectoryTree`` over a folder, to choose a ``.RUN`` file or an NMEA 0183 log anywhere.

↑ ↓ move, → or Enter opens a folder, Enter on a file chooses it, Backspace goes up to the
parent folder, Esc closes without choosing.  Hidden files (``.name``) are not listed.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from textual import on
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import DirectoryTree, Static

from uvnav_tui.keys_help import KeyHint

PICKER_KEYS: tuple[KeyHint, ...] = (
    ("Enter", "Choose/Open"),
    ("Esc", "Cancel"),
    ("Backspace", "Up"),
    ("↑↓", "Move"),
    ("F1", "Help"),
    ("Ctrl+Q", "Quit"),
)


class RunFileTree(DirectoryTree):
    """A directory tree without hidden entries."""

    def filter_paths(self, paths: Iterable[Path]) -> Iterable[Path]:
        """Every entry but those whose name starts with a dot."""
        return [p for p in paths if not p.name.startswith(".")]


class FilePicker(ModalScreen[Path | None]):
    """Dismissed with the chosen file's path, or None."""

    CSS_PATH = "file_picker.tcss"
    KEY_HINTS = PICKER_KEYS

    BINDINGS = [
        Binding("escape", "cancel", "Cancel", show=False, priority=True),
        Binding("backspace", "up", "Parent folder", show=False, priority=True),
    ]

    def __init__(self, folder: Path) -> None:
        super().__init__()
        self.folder = folder.resolve()

    def compose(self) -> ComposeResult:
        """The folder's name over its tree."""
        with Vertical(id="picker-frame") as frame:
            frame.border_title = "Run file: a .RUN file or an NMEA log"
            frame.border_subtitle = "Enter chooses  Backspace: parent  Esc cancels"
            yield Static(str(self.folder), id="picker-folder", markup=False)
            yield RunFileTree(self.folder, id="picker-tree")

    def on_mount(self) -> None:
        """The cursor in the tree."""
        self.query_one(RunFileTree).focus()

    def help_topic(self) -> str:
        """F1 in the picker."""
        return ("Choose the run: a .RUN file or an NMEA 0183 log (any name; recognised by its "
                "content). ↑ ↓ move, → or Enter opens a folder, Enter on a file chooses it, "
                "Backspace goes up to the parent folder, Esc cancels. A live source is typed "
                "in the field as a URL: udp://0.0.0.0:10110.")

    def action_up(self) -> None:
        """The tree of the parent folder."""
        parent = self.folder.parent
        if parent != self.folder:
            self.folder = parent
            self.query_one(RunFileTree).path = parent
            self.query_one("#picker-folder", Static).update(str(parent))

    def action_cancel(self) -> None:
        """Close without choosing."""
        self.dismiss(None)

    @on(DirectoryTree.FileSelected)
    def _chosen(self, event: DirectoryTree.FileSelected) -> None:
        event.stop()
        self.dismiss(Path(event.path))
