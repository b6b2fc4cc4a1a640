"""Benchmarks (``make bench``): figures are printed as medians and ratios, never asserted."""
