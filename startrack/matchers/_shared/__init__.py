"""Shared matcher machinery: pair lookups and joins, handedness, triple orders, and the
compiled kernels behind them (startrack._core). Every matcher builds on this package; no
matcher imports another."""

__all__: list[str] = []  # its modules are imported by name
