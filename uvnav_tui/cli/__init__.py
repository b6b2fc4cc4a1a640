"""The headless commands (``uvnav replay``, ``simulate``, ``script``, ``assess``) and the
console's entry point."""
