"""The run loop: the run configuration, the pure processing cycle
``step(context, nav, record) -> (nav', CycleResult)``, operator commands between cycles, the
session that drives a run and its logs, and the per-cycle record views (JSON lines,
``.OUT`` block)."""
