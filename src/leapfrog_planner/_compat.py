"""Old import paths, kept for one release.

Until version 0.2 the package was flat (``leapfrog_planner.planner``, ``.shooting``, ...); later
``experiments.direct`` moved to ``planning.direct``. Those names still import, as the modules
they moved to, with a :class:`DeprecationWarning` that names the new path. No module file is
kept for them: a finder on ``sys.meta_path`` resolves them.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: old module (under the package) -> the module it moved to
MOVED = {
    "models": "model",
    "pmp": "model.pmp",
    "codegen": "compiled.codegen",
    "kernels": "compiled.kernels",
    "penalty": "model.penalty",
    "problem": "integrate.problem",
    "shooting": "bvp.shooting",
    "multiple_shooting": "bvp.multiple_shooting",
    "scenario": "planning.scenario",
    "initial_path": "planning.initial_path",
    "path_ranking": "planning.path_ranking",
    "leapfrog": "planning.leapfrog",
    "planner": "planning.planner",
    "results": "planning.results",
    "paper": "experiments.paper",
    "bench": "experiments.bench",
    "peers": "experiments.peers",
    "profiling": "experiments.profiling",
    "direct": "planning.direct",
    "generate": "batch.generate",
    "sweep": "batch.sweep",
    "sweep_exec": "batch.engines",
    "sweep_store": "batch.store",
    "report": "batch.report",
    "plots": "viz.plots",
    "cli_experiments": "cli.experiments",
    "cli_sweep": "cli.batch",
    # Moved since: the direct method below batch, which runs it as a sweep method.
    "experiments.direct": "planning.direct",
}


class _OldPaths(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def __init__(self, package: str):
        self.prefix = package + "."
        self.package = package

    def find_spec(self, fullname, path=None, target=None):
        if fullname.startswith(self.prefix) and fullname[len(self.prefix) :] in MOVED:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        new = f"{self.package}.{MOVED[spec.name[len(self.prefix) :]]}"
        warnings.warn(f"{spec.name} moved to {new}", DeprecationWarning, stacklevel=2)
        return importlib.import_module(new)

    def exec_module(self, module):  # the module it moved to is already executed
        pass


def install(package: str) -> None:
    """Make the old paths of ``package`` importable (once per process)."""
    if not any(isinstance(f, _OldPaths) for f in sys.meta_path):
        sys.meta_path.append(_OldPaths(package))
