"""engine.filter."""
