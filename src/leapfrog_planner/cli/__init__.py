"""The ``leapfrog`` command: :mod:`.main` (the group, ``solve``, ``shoot``, ``derive``,
``scenarios`` and the error handling), :mod:`.experiments` (``paper``, ``bench``) and
:mod:`.batch` (``generate``, ``sweep``, ``report``)."""

from .main import main, run

__all__ = ["main", "run"]
