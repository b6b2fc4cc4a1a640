"""engine.lsq."""
