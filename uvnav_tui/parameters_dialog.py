"""Demo menu parameter dialogs, built from the configuration's own key tables.

Demo ▸ Parameters edits ``[demo]`` (sample interval, playback pace, plot scale and size, specific
weight …); in developer mode Demo ▸ Corrections / LS params / Filter params edit
``[corrections]``, ``[lsq]`` and ``[filter]`` (program.md §3 item 7, A4). Every value is checked
as it is typed by the configuration's own validation; OK sends one ``SetParameters`` command with
the changed keys.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from textual.app import ComposeResult
from textual.containers import VerticalScroll
from textual.widgets import Checkbox

from engine.commands import SetParameters
from engine.errors import InputError
from engine.runconfig import DECCA_CF_CONDITIONS, Key, decca_cf_condition, parse_decca_cf
from uvnav_tui.dialog import Dialog
from uvnav_tui.validated_field import ValidatedField

NUMBER_MESSAGE = "Wrong number input !"
WHOLE_NUMBER_MESSAGE = "Wrong whole number input !"

TABLE_TITLES = {
    "demo": "Demo ▸ Parameters",
    "corrections": "Demo ▸ Corrections",
    "lsq": "Demo ▸ LS params",
    "filter": "Demo ▸ Filter params",
}


def value_text(value: Any) -> str:
    """A configuration value as it is typed."""
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def key_parser(table: Any, key: Key) -> Callable[[str], Any]:
    """Parser of a typed value for ``key``, validated by the table's own checks."""

    def parse(text: str) -> Any:
        raw: Any
        if key.attr == "decca_cf":  # season × day/night by name, or a number (A8.2)
            raw = parse_decca_cf(text)
        elif key.kind == "float":
            try:
                raw = float(text.strip())
            except ValueError:
                raise InputError(NUMBER_MESSAGE, field=key.key, text=text) from None
        elif key.kind == "float_auto":  # "auto" or a number
            word = text.strip()
            try:
                raw = word if word.lower() == "auto" else float(word)
            except ValueError:
                raise InputError('"auto" or a number !', field=key.key, text=text) from None
        elif key.kind == "int":
            try:
                raw = int(text.strip())
            except ValueError:
                raise InputError(WHOLE_NUMBER_MESSAGE, field=key.key, text=text) from None
        else:
            raw = text.strip()
        checked = dataclasses.replace(table, **{key.attr: raw})
        return getattr(checked, key.attr)

    return parse


class ParametersDialog(Dialog[SetParameters]):
    """One field per key of a configuration table (booleans as check boxes)."""

    def __init__(self, table_name: str, table: Any) -> None:
        super().__init__()
        self.table_name = table_name
        self.table = table
        self.TITLE = TABLE_TITLES.get(table_name, table_name)
        self.keys: tuple[Key, ...] = tuple(
            k for k in type(table).KEYS if k.kind in ("float", "float_auto", "int", "str", "bool"))

    def compose_body(self) -> ComposeResult:
        """The fields in the table's key order."""
        with VerticalScroll(id="param-fields"):
            for key in self.keys:
                label = key.key if key.unit in ("—", "") else f"{key.key} ({key.unit})"
                value = getattr(self.table, key.attr)
                if key.attr == "decca_cf":
                    label = f"{key.key} ({', '.join(DECCA_CF_CONDITIONS)} or a number)"
                    value = decca_cf_condition(value) or value
                if key.kind == "bool":
                    yield Checkbox(label, value, id=f"param-{key.attr}", compact=True)
                else:
                    yield ValidatedField(label, value_text(value), key_parser(self.table, key),
                                         id=f"param-{key.attr}")

    def on_mount(self) -> None:
        """Focus the first field."""
        first = self.query("#param-fields > *").first()
        if isinstance(first, ValidatedField):
            first.focus_input()
        else:
            first.focus()

    def collect(self) -> SetParameters | None:
        """A command with the changed keys (validated together), or None."""
        if self.first_invalid() is not None:
            return None
        changes: dict[str, Any] = {}
        for key in self.keys:
            widget = self.query_one(f"#param-{key.attr}")
            if isinstance(widget, Checkbox):
                value: Any = widget.value
            else:
                assert isinstance(widget, ValidatedField)
                value = widget.parsed
            if value != getattr(self.table, key.attr):
                changes[key.attr] = value
        try:
            dataclasses.replace(self.table, **changes)
        except InputError as exc:
            self.set_message(exc.message)
            return None
        return SetParameters(self.table_name, tuple(changes.items()))
