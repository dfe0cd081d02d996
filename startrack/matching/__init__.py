"""Shared matcher machinery: pair lookups and joins, handedness, triple orders, and the
compiled (numba) kernels behind them. Every matcher builds on this package; no matcher
imports another."""
