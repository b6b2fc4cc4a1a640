"""Widgets of the console: menu bar, pulldowns, state line, status column, message line and
panel, validated fields, toggles and the braille canvas."""
