"""The compiled kernels of a vehicle model: generated once, cached on disk, loaded fast.

The generated module (see :mod:`.codegen`) lives in the user's cache directory; numba caches its
machine code beside it, so each model compiles once per machine. Its name carries the cache key
(:mod:`.cache_key`: the model's source and every file that feeds the module), so a warm start
loads the module without importing SymPy at all.
"""

from __future__ import annotations

import hashlib
import importlib.util
import logging
import sys
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any

import numba
import numpy as np
from numba.core.dispatcher import Dispatcher

from .._atomic import write_atomic
from .._cache import (
    cache_dir,
    check_numba_cache_loads,
    copy_atomic,
    copy_compiled,
    numba_cache_of,
    writable_dir,
)
from ..errors import ModelError
from ..model import MODELS, builtin_source, get_model
from ..model.aid import PlanningAid
from ..model.bounds import bound_parameters
from .cache_key import cache_key

log = logging.getLogger(__name__)


def _key(model) -> str:
    """The cache key of ``model``'s module (a built-in name or a ``VehicleModel``): see
    :mod:`.cache_key`."""
    return cache_key(builtin_source(model) if isinstance(model, str) else model.fingerprint())


@cache
def load_kernels(model) -> ModuleType:
    """The compiled kernel module of ``model`` (a built-in name or a ``VehicleModel``)."""
    if isinstance(model, str) and model not in MODELS:
        raise ModelError(f"unknown model {model!r} (known: {', '.join(MODELS)})")
    mod_name = _module_name(model)
    name = model if isinstance(model, str) else model.name
    if mod_name in sys.modules:
        return sys.modules[mod_name]
    path, home = _module_paths(mod_name)
    if not path.exists() and not _copy_read_only(path, home):
        _generate(model, path)
    try:
        _check_integrity(path)
        return _import(mod_name, path)
    except Exception as exc:  # a damaged cache entry: report it, build it again, once
        log.warning(
            "warning: damaged kernel cache for %s (%s): rebuilding it", name, type(exc).__name__
        )
        sys.modules.pop(mod_name, None)
        remove_cached(path)
        _generate(model, path)
        return _import(mod_name, path)


def _module_name(model) -> str:
    """The name of ``model``'s generated module: its name made an identifier, and its key."""
    name = model if isinstance(model, str) else model.name
    return "lfp_" + "".join(ch if ch.isalnum() else "_" for ch in name) + "_" + _key(model)


def generated(model) -> bool:
    """Whether ``model``'s module is loaded or in the cache directory (or its read-only home):
    a look that generates nothing."""
    mod_name = _module_name(model)
    return mod_name in sys.modules or any(p.is_file() for p in _module_paths(mod_name))


def _module_paths(mod_name: str) -> tuple[Path, Path]:
    """Where the module ``mod_name`` is loaded from (the cache directory, or the writable
    fallback where that is read-only) and its home in the cache directory (the same path
    where the cache directory is writable)."""
    return writable_dir("models") / f"{mod_name}.py", cache_dir() / "models" / f"{mod_name}.py"


def _copy_read_only(path: Path, source: Path) -> bool:
    """Where the cache directory is read-only, copy its entry of ``path`` (the module and
    numba's files of it) to the writable fallback ``path`` is in, so that numba loads it from
    there instead of compiling it again (22.5 s instead of 0.9 s, measured). Numba needs a
    writable cache folder; its index is keyed by the module's content, so a copy is as good
    as the original. ``source``: its home in the cache directory."""
    home = source.parent
    if path == source or not source.is_file():
        return False
    try:
        copy_compiled(home / "__pycache__", numba_cache_of(path.parent), source.stem)
        copy_atomic(source, path)  # last: its presence means the copy is complete
    except OSError as exc:
        log.info("could not copy the read-only kernel cache entry %s: %s", source.name, exc)
        return False
    log.info("using the read-only kernel cache entry %s through a copy in %s", source, path)
    return True


#: The last line of a generated module: the SHA-256 of the text before it.
_SEAL = "# sha256 of the text above: "


def _generate(model, path: Path) -> None:
    from .codegen import module_text  # SymPy only when generating

    text = sealed(module_text(get_model(model)))
    # atomic: concurrent processes write identical text; an interrupt leaves no temporary file
    write_atomic(path, lambda tmp: Path(tmp).write_bytes(text.encode()))


def sealed(text: str) -> str:
    """``text`` with its seal as the last line (:func:`_check_integrity`)."""
    text = text.rstrip("\n") + "\n"
    return f"{text}{_SEAL}{hashlib.sha256(text.encode()).hexdigest()}\n"


class DamagedModule(ValueError):
    """A generated module whose text is not what was generated (empty, cut, edited)."""


def _check_integrity(path: Path) -> None:
    """Refuse a generated module whose last line is not the seal of the text before it: a
    file cut short, emptied or edited is built again, never imported."""
    data = path.read_bytes()
    body, _, seal = data.rstrip(b"\n").rpartition(b"\n")
    body += b"\n"
    expected = f"{_SEAL}{hashlib.sha256(body).hexdigest()}".encode()
    if seal != expected:
        raise DamagedModule(f"{path.name}: its seal does not match its text")


def _import(mod_name: str, path: Path) -> ModuleType:
    check_numba_cache_loads()  # the module's compiled code is loaded from numba's cache checked
    spec = importlib.util.spec_from_file_location(mod_name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[mod_name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(mod_name, None)
        raise
    return module


def entry_point(kernel, args: tuple):
    """The machine code of ``kernel`` for the types of ``args``, compiled or loaded from numba's
    disk cache on first use, callable as ``kernel`` is.

    A call through it skips numba's dispatch, which types every argument on every call: for a
    record (a NamedTuple, typed in Python field by field) that costs microseconds, more than the
    call itself (the flow's integrator: 11 us through the dispatcher, 1 us through its entry
    point, measured). The caller must then pass arguments of these types on every call (the
    owner builds them: see ``Flow._run``). Without the JIT (``NUMBA_DISABLE_JIT``), the kernel.
    """
    if not isinstance(kernel, Dispatcher):
        return kernel
    key = (kernel, _fingerprint(args))
    entry = _ENTRY_POINTS.get(key)
    if entry is None:
        entry = kernel.compile(tuple(numba.typeof(a) for a in args))
        if key[1] is not None:
            _ENTRY_POINTS[key] = entry
    return entry


#: Entry points by kernel and the fingerprint of their arguments' types (:func:`_fingerprint`):
#: numba's ``typeof`` of a plan's records costs about 0.5 ms a call, and Leapfrog binds a
#: shooter's entry point some 20 times a plan (measured on the general preset).
_ENTRY_POINTS: dict[tuple, Any] = {}


def _fingerprint(value):
    """What numba's type of ``value`` depends on, for arrays, scalars and tuples of them
    (records are NamedTuples: their class is part of it); None for anything else (not cached)."""
    if isinstance(value, np.ndarray):
        f = value.flags
        return (value.dtype.str, value.ndim, f.c_contiguous, f.f_contiguous, f.writeable, f.aligned)
    if isinstance(value, tuple):
        parts = tuple(_fingerprint(v) for v in value)
        return None if None in parts else (type(value), parts)
    if type(value) in (float, int, bool):
        return type(value)
    return None


def cached_entry_point(kernel, args: tuple):
    """:func:`entry_point` where numba has that machine code already, in memory or in its disk
    cache; None where getting it would mean compiling (a fresh machine). It takes the steps of
    numba's ``Dispatcher.compile`` up to its compiling; where numba's inner workings are not as
    expected, it compiles as :func:`entry_point` does."""
    if not isinstance(kernel, Dispatcher):
        return kernel
    sig = tuple(numba.typeof(a) for a in args)
    existing = kernel.overloads.get(sig)
    if existing is not None:
        return existing.entry_point
    try:
        from numba.core.compiler_lock import global_compiler_lock

        with global_compiler_lock:
            cres = kernel._cache.load_overload(sig, kernel.targetctx)
            if cres is None:
                return None
            kernel.targetctx.insert_user_function(cres.entry_point, cres.fndesc, [cres.library])
            kernel.add_overload(cres)
            return cres.entry_point
    except AttributeError:  # another numba: its way, compiling if need be
        return kernel.compile(sig)


def remove_cached(path: Path) -> None:
    """Remove a generated module and numba's cache files of it (``__pycache__/<stem>.*``)."""
    for p in [path, *path.parent.glob(f"__pycache__/{path.stem}.*")]:
        try:
            p.unlink()
        except OSError:
            pass


@dataclass(frozen=True)
class ModelInfo:
    """What the numerics need to know about a model, read from its generated module."""

    name: str
    states: tuple[str, ...]
    controls: tuple[str, ...]
    parameters: tuple[str, ...]
    defaults: tuple[float, ...]
    positive: tuple[bool, ...]
    nonnegative: tuple[bool, ...]  # declared so in the model (positive ones too)
    description: str
    aid: PlanningAid | None
    definition: Any = field(repr=False, compare=False)  # a built-in name or a VehicleModel

    @property
    def nx(self) -> int:
        return len(self.states)

    @property
    def nu(self) -> int:
        return len(self.controls)

    def parameter_values(self, overrides: dict[str, float] | None = None) -> tuple[float, ...]:
        """Default parameter values with ``overrides`` (by name); unknown names are errors."""
        overrides = dict(overrides or {})
        unknown = sorted(set(overrides) - set(self.parameters))
        if unknown:
            known = ", ".join(self.parameters) or "none"
            raise ModelError(
                f"model {self.name!r} has no parameter {unknown[0]!r} (known: {known})"
            )
        return tuple(
            float(overrides.get(n, d)) for n, d in zip(self.parameters, self.defaults, strict=True)
        )

    @property
    def robot_parameters(self) -> tuple[str, ...]:
        """The model's own parameters (the robot's dimensions): all but the controls' bounds,
        which the planner sets from a scenario's bounds."""
        extra = set(bound_parameters(self.controls))
        return tuple(p for p in self.parameters if p not in extra)

    @property
    def kernels(self) -> ModuleType:
        return load_kernels(self.definition)


def model_info(model) -> ModelInfo:
    """Metadata of ``model`` (a built-in name, a ``VehicleModel`` or a ``ModelInfo``)."""
    if isinstance(model, ModelInfo):
        return model
    K = load_kernels(model)
    return ModelInfo(
        name=K.MODEL_NAME,
        states=K.STATE_NAMES,
        controls=K.CONTROL_NAMES,
        parameters=K.PARAMETER_NAMES,
        defaults=K.PARAMETER_DEFAULTS,
        positive=K.PARAMETER_POSITIVE,
        nonnegative=K.PARAMETER_NONNEGATIVE,
        description=K.DESCRIPTION,
        aid=PlanningAid(*K.PLANNING_AID) if K.PLANNING_AID else None,
        definition=model,
    )
