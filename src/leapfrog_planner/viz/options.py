"""The settings of a saved figure that the command line offers too (light: no matplotlib)."""

from __future__ import annotations

#: Pixels per inch of a saved figure: the default, and the range accepted.
DPI, DPI_MIN, DPI_MAX = 150, 10, 1200
