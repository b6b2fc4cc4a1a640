"""engine.assess.accuracy."""
