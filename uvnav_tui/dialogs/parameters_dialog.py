"""Demo menu parameter dialogs, built from the configuration's own key tables.

Demo ▸ Parameters edits ``[demo]`` (sample interval, playback pace, plot scale and size, specific
weight …); in developer mode Demo ▸ Corrections / LS params / Filter params edit
``[corrections]``, ``[lsq]`` and ``[filter]`` (THEORY §12.6 item 7, D36). Every value is checked
as it is typed by the configuration's own validation; OK sends one ``SetParameters`` command with
the changed keys.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from textual import events
from textual.app import ComposeResult
from textual.containers import VerticalScroll
from textual.widgets import Checkbox, Static

from engine import api
from engine.api import DECCA_CF_CONDITIONS, InputError, Key, decca_cf_condition, parse_decca_cf
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.widgets.toggles import GlyphCheckbox
from uvnav_tui.widgets.validated_field import ValidatedField, number_text

if TYPE_CHECKING:
    from engine.api import SetParameters

NUMBER_MESSAGE = "Wrong number input !"
WHOLE_NUMBER_MESSAGE = "Wrong whole number input !"

TABLE_TITLES = {
    "demo": "Demo ▸ Parameters",
    "corrections": "Demo ▸ Corrections",
    "lsq": "Demo ▸ LS params",
    "filter": "Demo ▸ Filter params",
}


LABELS: dict[str, str] = {
    # [demo]
    "delta_t_s": "Sample interval",
    "s_weight": "Specific weight of seawater",
    "press_ref_freq_hz": "Pressure reference frequency",
    "plot_scale_m": "Plot scale",
    "plot_size": "Plot size (relative)",
    "pace": "Playback pace",
    "poe_expansion_m_h": "Pool of Errors expansion",
    # [corrections]
    "gps_north_m": "GPS correction north",
    "gps_east_m": "GPS correction east",
    "decca_red_lanes": "Decca Red correction",
    "decca_green_lanes": "Decca Green correction",
    "decca_purple_lanes": "Decca Purple correction",
    # [lsq]
    "lop_reject": "LOP rejection (A/Y/N)",
    "reliab_interval_pct": "Significance level α",
    "conf_region_pct": "Confidence region",
    "scale_vcv": "Scale a-priori VCV by S²",
    "epsilon_m": "LS break-off ε",
    "s02": "A-priori variance factor σ0²",
    "decca_cf": "Decca CF (auto/SD/WD/SN/WN/no.)",
    "gps_se_sf": "GPS VCV scale factor",
    "estimator": "Estimator",
    "sigma_compass_deg": "σ compass-repeater bearing",
    "sigma_periscope_deg": "σ periscope bearing",
    "sigma_radar_bearing_deg": "σ radar bearing",
    "sigma_radar_range_m": "σ radar distance",
    # [filter]
    "on": "Kalman filtering on",
    "model": "Filter model",
    "p0": "Initial covariance P0",
    "q_scale": "System noise Q factor",
    "q_mode": "Q discretisation",
    "turn_rate_max_deg_s": "Max. rate of turn",
    "pitch_rate_max_deg_s": "Max. pitch rate",
    "sigma_incl_deg": "σ inclinometer",
    "sigma_gyro_deg": "σ gyro heading",
    "sigma_press_m": "σ pressure depth",
    "log_sigma_frac": "σ log (fraction of speed)",
    "log_sigma_floor_ms": "σ log, lower bound",
    "fix_tau_s": "Fix-error correlation time",
    "fix_sigma_frac": "Correlated part of fix var.",
    "dr_sigma_m": "σ operator DR position",
    "bias_noise": "Biases drift (random walk)",
    "log_bias_rw_ms_sqrth": "Log bias random walk",
    "gyro_bias_rw_deg_sqrth": "Gyro bias random walk",
    "incl_bias_rw_deg_sqrth": "Incl. bias random walk",
}
"""Operator labels of the configuration keys (the TOML key is shown in the help line)."""

UNIT_SYMBOLS = {"deg": "°", "deg/s": "°/s", "deg/√h": "°/√h"}


def key_label(key: Key) -> str:
    """``Pressure reference frequency (Hz)``: the operator label with the unit, if any."""
    label = LABELS.get(key.attr, key.key.replace("_", " ").capitalize())
    if key.unit in ("—", "", "zone+lane", "path"):
        return label
    return f"{label} ({UNIT_SYMBOLS.get(key.unit, key.unit)})"


def value_text(value: Any) -> str:
    """A configuration value as it is typed, every digit kept (``39939.662``, not ``39939.7``)."""
    return number_text(value)


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


FILE_ONLY_KEYS = frozenset({"sigma_current2", "sigma_a2", "adapt_window", "adapt_clip",
                            "adapt_fix_max", "recover", "recover_epochs", "recover_gap_s",
                            "adapt_dr", "adapt_dr_horizon_s", "adapt_dr_min", "adapt_dr_max"})
"""Keys set in the configuration file only, not in the dialog: the filter's current and
acceleration noise densities (m²/s³) follow the vessel (the dialog's ``vessel`` field sets
them, docs/CONFIG.md "The vessel decision"), the adaptation's window, clip and bound (the
dialog has its on/off switch, ``adapt``), the divergence remedy (``recover`` and its K and
G, THEORY §8.18) and the learnt dead-reckoning factor (``adapt_dr*``, off by default, THEORY
§8.19); the file is the place for a deliberate value. It
also keeps the Filter list whole on a 160×50 terminal."""

FRAME_ROWS = 8
"""Rows of a parameter dialog that are not the field list: border 2, help 2, message 1,
buttons 1, and a margin of 2 so the page stays visible above and below."""


class ParametersDialog(Dialog["SetParameters"]):
    """One field per key of a configuration table (booleans as check boxes)."""

    CSS_PATH = ["dialog.tcss", "parameters_dialog.tcss"]

    def __init__(self, table_name: str, table: Any) -> None:
        super().__init__()
        self.table_name = table_name
        self.table = table
        self.TITLE = TABLE_TITLES.get(table_name, table_name)
        self.keys: tuple[Key, ...] = tuple(
            k for k in type(table).KEYS
            if k.kind in ("float", "float_auto", "int", "str", "bool")
            and k.attr not in FILE_ONLY_KEYS)

    def compose_body(self) -> ComposeResult:
        """The fields in the table's key order, then the help line of the focused field."""
        with VerticalScroll(id="param-fields"):
            for key in self.keys:
                label = key_label(key)
                value = getattr(self.table, key.attr)
                if key.attr == "decca_cf":
                    value = decca_cf_condition(value) or value
                if key.kind == "bool":
                    yield GlyphCheckbox(label, value, id=f"param-{key.attr}", compact=True)
                else:
                    yield ValidatedField(label, value_text(value), key_parser(self.table, key),
                                         id=f"param-{key.attr}")
        yield Static("", id="param-help", classes="dialog-note", markup=False)

    def help_text(self, key: Key) -> str:
        """``[demo] press_ref_freq_hz: …``: the TOML key and its meaning (literal text)."""
        extra = ""
        if key.attr == "decca_cf":
            extra = " (" + ", ".join(f"{c} {n}" for c, (n, _v) in DECCA_CF_CONDITIONS.items()) + ")"
        return f"[{self.table_name}] {key.key}: {key.doc}{extra}"

    def field_help(self) -> str:
        """Every field: its label, TOML key and meaning (the line under the list shows the
        focused one's)."""
        head = ("Each value is checked as typed by the configuration's own rules; numbers are "
                "written as in the TOML file (12, 0.5, 1e-05). OK sends the changed keys.")
        return "\n".join([head, ""] + [f"{key_label(k)}: {self.help_text(k)}"
                                        for k in self.keys])

    def on_descendant_focus(self, event: events.DescendantFocus) -> None:
        """Explain the focused field in the help line."""
        node: Any = event.widget
        while node is not None and not isinstance(node, (ValidatedField, Checkbox)):
            node = node.parent
        if node is None:
            return
        attr = node.id.removeprefix("param-")
        key = next((k for k in self.keys if k.attr == attr), None)
        if key is not None:
            self.query_one("#param-help", Static).update(self.help_text(key))

    def on_resize(self) -> None:
        """Give the fields every row the terminal has (the list scrolls only when it must)."""
        self._fit()

    def _fit(self) -> None:
        rows = self.app.size.height - FRAME_ROWS
        self.query_one("#param-fields", VerticalScroll).styles.max_height = max(rows, 4)

    def on_mount(self) -> None:
        """Fit the list to the terminal; focus the first field."""
        self._fit()
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
                value = widget.value_or(getattr(self.table, key.attr))
            if value != getattr(self.table, key.attr):
                changes[key.attr] = value
        try:
            dataclasses.replace(self.table, **changes)
        except InputError as exc:
            self.set_message(exc.message)
            return None
        return api.SetParameters(self.table_name, tuple(changes.items()))
