"""Kalman ▸ Predict.: time interval (minutes) and step size (seconds) of a prediction of the
filter state and its VCV (thesis §6.3.3, L7095–7101, L7643)."""

from __future__ import annotations

from textual.app import ComposeResult
from textual.widgets import Static

from engine.api import InputError, parse_plain_number
from uvnav_tui.dialogs.dialog import NUMBER_HELP, Dialog
from uvnav_tui.widgets.validated_field import ValidatedField

INTERVAL_MESSAGE = "Wrong time interval input !"
STEP_MESSAGE = "Wrong step size input !"
MAX_INTERVAL_MIN = 24 * 60.0
MAX_ROWS = 2000


def _positive(text: str, message: str, limit: float, least: float = 0.0, *,
              field: str) -> float:
    """A plain decimal number (as in every navigation dialog: no exponent, so ``1e3`` is
    refused here as in Obs ▸ Distance) in (0, limit], and at least ``least`` when that is
    above 0."""
    value = parse_plain_number(text, message, field=field)
    if not (0.0 < value <= limit and value >= least):
        raise InputError(message, field=field, text=text)
    return value


def parse_interval_min(text: str) -> float:
    """Prediction interval in minutes, 0 < t ≤ 24 h."""
    return _positive(text, INTERVAL_MESSAGE, MAX_INTERVAL_MIN, field="time interval")


MIN_STEP_S = 1.0
"""The table's times are to the second: a shorter step gave rows with the same time."""


def parse_step_s(text: str) -> float:
    """Step size in seconds, 1 s ≤ s ≤ 24 h."""
    return _positive(text, STEP_MESSAGE, MAX_INTERVAL_MIN * 60.0, MIN_STEP_S,
                     field="step size")


class PredictDialog(Dialog[tuple[float, float]]):
    """Dismissed with (horizon in seconds, step in seconds)."""

    CANCEL_IF_UNCHANGED = False

    TITLE = "Kalman ▸ Predict."
    HELP = f"""
Predicts the position and its error ellipse from the last filter state; the run is not changed.
Time interval (min): more than 0, at most 1440 (24 h).
Step size (s): at least 1, at most the interval, at most 2000 steps.
{NUMBER_HELP}
"""
    OK_LABEL = "Predict"

    def compose_body(self) -> ComposeResult:
        """Interval and step fields."""
        yield ValidatedField("Time interval (min)", "10", parse_interval_min, id="predict-interval")
        yield ValidatedField("Step size (s)", "60", parse_step_s, id="predict-step")
        yield Static("Predicts from the last cycle's filter state; the run is not changed.",
                     classes="dialog-note")

    def on_mount(self) -> None:
        """Cursor in the interval field."""
        self.query_one("#predict-interval", ValidatedField).focus_input()

    def collect(self) -> tuple[float, float] | None:
        """(horizon, step) in seconds if valid (step ≤ interval, at most 2000 steps)."""
        if self.first_invalid() is not None:
            return None
        horizon = float(self.query_one("#predict-interval", ValidatedField).parsed) * 60.0
        step_field = self.query_one("#predict-step", ValidatedField)
        step = float(step_field.parsed)
        if step > horizon or horizon / step > MAX_ROWS:
            self.set_message(f"{STEP_MESSAGE} (step ≤ interval, at most {MAX_ROWS} steps)")
            step_field.focus_input()
            return None
        return horizon, step
