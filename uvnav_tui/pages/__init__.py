"""uvnav_tui.pages.pages."""
