"""The action registry (the menu tree) and its handlers agree: every leaf has a handler, and
the needs-a-run flags are where the console refuses an action without a run."""

from __future__ import annotations

import inspect

from uvnav_tui.actions import MenuActions
from uvnav_tui.menus import ACTIONS, palette_entries
from uvnav_tui.pages.registry import page_titles


def test_every_menu_action_has_a_handler() -> None:
    for action in ACTIONS:
        if action.startswith("page:"):
            assert int(action.split(":", 1)[1]) in page_titles()
        else:
            handler = getattr(MenuActions, action, None)
            assert inspect.isfunction(handler), action
            assert list(inspect.signature(handler).parameters) == ["self"], action


def test_needs_run_flags() -> None:
    assert {a for a, item in ACTIONS.items() if item.needs_run} == {
        "datum", "dr_pos", "current", "gps", "decca", "sensors", "obs_bearing", "obs_distance",
        "obs_radar", "filtering", "predict", "smoothing", "demo_params", "demo_corrections",
        "demo_lsq", "demo_filter", "run_continue", "run_suspend",
    }


def test_the_palette_reads_the_registries() -> None:
    """Navigator mode: every visible menu leaf, then every page below the developer pages."""
    entries = list(palette_entries(False))
    assert ("Setup ▸ Systems ▸ GPS", "GPS on/off and receiver type", "gps") in entries
    assert ("Pg 642 Position plot", "Show page 642", "page:642") in entries
    assert not any(action == "page:850" and title.startswith("Pg") for title, _, action in entries)
    assert any(action == "page:850" for _, _, action in palette_entries(True))
