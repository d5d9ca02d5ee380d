"""Two-point boundary value problems: simple and multiple shooting."""
