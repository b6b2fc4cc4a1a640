"""uvnav_tui.cli.main."""
