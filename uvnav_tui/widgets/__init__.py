"""uvnav_tui.widgets."""
