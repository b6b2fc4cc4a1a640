"""uvnav_tui.screens."""
