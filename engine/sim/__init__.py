"""engine.sim."""
