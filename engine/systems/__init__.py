"""engine.systems."""
