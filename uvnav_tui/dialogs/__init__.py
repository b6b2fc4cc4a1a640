"""uvnav_tui.dialogs."""
