"""Imported by multiprocessing's forkserver only (its preload): it dies with the sweep."""

import os

from .orphans import die_with_parent, expected_parent

die_with_parent(expected_parent())
#: The parent of every worker forked from this server.
SERVER = os.getpid()
