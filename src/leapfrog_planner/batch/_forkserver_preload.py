"""Imported by multiprocessing's forkserver only (its preload): it dies with the sweep."""

from .orphans import die_with_parent

die_with_parent()
