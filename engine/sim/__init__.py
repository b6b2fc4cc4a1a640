"""The simulator: a mission scenario (TOML) turned into ``.RUN`` records and the truth."""
