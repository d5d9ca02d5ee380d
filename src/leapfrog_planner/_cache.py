"""Where compiled code is kept on disk, also when the installation or the cache is read-only.

Two caches: the project's own (generated model modules and their compiled code, the Runge-Kutta
tableaux) in ``cache_dir()``, and numba's cache of the package's own compiled functions, which
numba keeps in ``__pycache__`` beside their source, else in the user's cache folder. Where neither
is writable (a read-only installation and home, as on some clusters), numba cannot even define a
cached function, and importing the package would fail. ``use_writable_numba_cache`` is run before
any such function is defined: it points numba at a writable folder seeded with the files compiled
beside the package, so that a warm read-only installation is used as it is, not compiled again.
"""

from __future__ import annotations

import logging
import os
import shutil
import stat
import sys
import tempfile
import threading
from pathlib import Path

from ._atomic import write_atomic

log = logging.getLogger(__name__)

PACKAGE = Path(__file__).resolve().parent

__all__ = [
    "cache_dir",
    "check_numba_cache_loads",
    "copy_atomic",
    "copy_compiled",
    "numba_cache_of",
    "private_temp_root",
    "use_writable_numba_cache",
    "writable_dir",
]


def cache_dir() -> Path:
    """Where generated modules live: ``$LEAPFROG_CACHE_DIR``, else the user's cache directory."""
    env = os.environ.get("LEAPFROG_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "leapfrog-planner"


def writable_dir(name: str) -> Path:
    """``cache_dir() / name``, created; where that cannot be written (a read-only home), the
    same name in a folder of the temporary directory that is the user's alone
    (:func:`private_temp_root`): code found there is imported, so no other user may write it."""
    d = cache_dir() / name
    try:
        d.mkdir(parents=True, exist_ok=True)
        probe = d / f".probe-{os.getpid()}-{threading.get_ident()}"  # threads probe too
        probe.write_text("")
        probe.unlink()
        return d
    except OSError:
        d = private_temp_root() / name
        d.mkdir(mode=0o700, parents=True, exist_ok=True)
        return d


def private_temp_root() -> Path:
    """``<tmp>/leapfrog-planner-<uid>``, created with mode 0700, and used only if it is a real
    folder (not a link) that this user owns and nobody else may write or enter; otherwise (a
    folder planted by another user, or opened to others) a fresh private folder of this
    process (``tempfile.mkdtemp``), whose code is compiled again."""
    uid = os.getuid() if hasattr(os, "getuid") else 0
    root = Path(tempfile.gettempdir()) / f"leapfrog-planner-{uid}"
    try:
        root.mkdir(mode=0o700)
    except FileExistsError:
        pass
    except OSError:
        return Path(tempfile.mkdtemp(prefix="leapfrog-planner-"))
    try:
        st = os.lstat(root)
    except OSError:
        return Path(tempfile.mkdtemp(prefix="leapfrog-planner-"))
    private = stat.S_ISDIR(st.st_mode) and st.st_uid == uid and not st.st_mode & 0o077
    if not private:
        log.warning("%s is not private to this user: not used, compiling in a fresh folder", root)
        return Path(tempfile.mkdtemp(prefix="leapfrog-planner-"))
    return root


def copy_atomic(source: Path, target: Path) -> None:
    """Copy ``source`` to ``target`` (folders created); concurrent copies write the same bytes.
    The modification time is kept too: numba before 0.68 keys its cache by the source's time."""
    target.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(target, lambda tmp: shutil.copy2(source, tmp))


def _writable(folder: Path) -> bool:
    while not folder.exists():
        folder = folder.parent
    return os.access(folder, os.W_OK | os.X_OK)


def use_writable_numba_cache() -> None:
    """If numba cannot write beside the package, give it a writable cache folder, seeded with
    the package's compiled files (numba keys them by the source's content, so copies are valid).
    ``NUMBA_CACHE_DIR``, when set, is the user's choice and is left alone. Cheap when the
    package is writable: numba is not even imported."""
    numba = sys.modules.get("numba")
    chosen = numba.config.CACHE_DIR if numba else os.environ.get("NUMBA_CACHE_DIR")
    if chosen or _writable(PACKAGE / "model" / "__pycache__"):
        return
    try:
        target = writable_dir("numba")
    except OSError as exc:
        log.info("no writable folder for numba's cache (%s): compiling without it", exc)
        return
    os.environ["NUMBA_CACHE_DIR"] = str(target)  # read by numba when it is imported
    import numba

    numba.config.CACHE_DIR = str(target)  # in case it was imported before
    for pycache in sorted(PACKAGE.rglob("__pycache__")):
        try:
            copy_compiled(pycache, numba_cache_of(pycache.parent))
        except OSError as exc:
            log.info("could not copy %s into numba's cache: %s", pycache, exc)
    log.info("the package is read-only: numba's cache is %s", target)


def numba_cache_of(folder: Path) -> Path:
    """Where numba keeps the compiled code of the modules in ``folder``."""
    import numba
    from numba.core.caching import _CacheLocator

    if not numba.config.CACHE_DIR:
        return folder / "__pycache__"
    subpath = _CacheLocator.get_suitable_cache_subpath(str(folder / "module.py"))
    return Path(numba.config.CACHE_DIR) / subpath


def copy_compiled(source: Path, target: Path, stem: str = "") -> None:
    """Copy numba's files (of the modules named ``stem``, default all) from ``source`` to
    ``target``, data files before their index, skipping those already there."""
    for f in sorted(source.glob(f"{stem or '*'}.*nb[ic]")):
        if not (target / f.name).exists():
            copy_atomic(f, target / f.name)


#: The modules whose compiled functions :func:`check_numba_cache_loads` checks: the package's
#: own and the generated kernel modules (``lfp_<model>_<key>``).
_CHECKED_MODULES = ("leapfrog_planner.", "lfp_")


def check_numba_cache_loads() -> None:
    """Make numba refuse a file of its disk cache that holds another function's code.

    numba finds a function's compiled code through an index that names a data file per
    signature, and loads whatever that file holds: a damaged cache (two data files swapped, or
    one copied over another) makes it run the wrong machine code, a failure on every run that
    never heals (a ``TypeError`` deep in numba, or wrong numbers). Each load of the package's
    functions is checked here against the function and the signature asked for; a file that does
    not match is said and not used, so numba compiles that function again and writes the file
    anew: the cache heals on that run. Installed once, before any of the package's compiled
    functions runs (:mod:`._jit`)."""
    from numba.core.caching import FunctionCache

    load = getattr(FunctionCache, "_load_overload", None)
    if load is None or getattr(FunctionCache, "_checked_by_leapfrog", False):
        return  # checked already, or another numba: its own loading, unchecked

    def _load_overload(self, sig, target_context):
        cres = load(self, sig, target_context)
        func = self._py_func
        if cres is None or not f"{func.__module__}.".startswith(_CHECKED_MODULES):
            return cres
        if cres.fndesc.qualname != func.__qualname__ or tuple(cres.signature.args) != tuple(sig):
            log.warning(
                "warning: numba's cache file of %s.%s holds other code (a damaged cache):"
                " compiling it again",
                func.__module__,
                func.__qualname__,
            )
            return None
        return cres

    FunctionCache._load_overload = _load_overload
    FunctionCache._checked_by_leapfrog = True
