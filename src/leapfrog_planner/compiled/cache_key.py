"""The cache key of a model's generated kernel module: a hash of everything that shapes it.

numba's disk cache keys a function by its own file and does not notice a change in a function
that a cached function calls (the templates call the penalty, which numba caches apart), so the
key of the generated module must change with every file whose code is compiled into it or
shapes its text. Those files are found, not listed: every module of this subpackage (the
generator, the templates, the records, the loader) and, transitively, every module of the
package that one of them imports, anywhere in its text (imports inside functions included),
read with ``ast``. The key hashes their paths and texts, numba's version and the model's own
source. Finding them reads and parses a few files and imports nothing: a warm start never loads
SymPy. Parsing them took 30-50 ms of every start, so what each file imports is kept in the cache
folder (``imports.json``), by the file's path and the hash of its text, for the package's
layout (its module files): a start reads and hashes the texts and parses none that it knows.
"""

from __future__ import annotations

import ast
import contextlib
import hashlib
import json
import os
from collections.abc import Callable
from functools import cache
from pathlib import Path

import numba

from .._atomic import write_atomic
from .._cache import cache_dir

#: The package's folder; files are named by their path below it.
PACKAGE = Path(__file__).resolve().parent.parent
HERE = Path(__file__).resolve().parent

Reader = Callable[[Path], str]


def _module_file(names: list[str]) -> Path | None:
    """The file of the package's module ``names`` (below the package), if there is one."""
    if not names:
        return PACKAGE / "__init__.py"
    base = PACKAGE.joinpath(*names)
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def _from_names(node: ast.ImportFrom, package: list[str]) -> list[str] | None:
    """The module that ``from ... import`` reads from, below the package; None outside it."""
    module = node.module.split(".") if node.module else []
    if node.level:
        if node.level - 1 > len(package):
            return None
        return package[: len(package) - node.level + 1] + module
    if module[:1] == [PACKAGE.name]:
        return module[1:]
    return None


def _imports(body: list[ast.stmt]):
    """The import statements of ``body``, nested ones included (only statements are visited:
    an import is never part of an expression, and expressions are most of the nodes)."""
    for node in body:
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node
        for field in ("body", "orelse", "finalbody", "handlers", "cases"):
            yield from _imports(getattr(node, field, None) or [])


def imported_files(path: Path, text: str) -> set[Path]:
    """The package's module files that the module at ``path`` (whose source is ``text``)
    imports, at the top or anywhere below. ``from m import x`` counts ``m.x`` where ``x`` is a
    module, else ``m``; an import of a module does not count its parent packages."""
    package = list(path.relative_to(PACKAGE).parent.parts)
    found: set[Path | None] = set()
    for node in _imports(ast.parse(text).body):
        if isinstance(node, ast.Import):
            for alias in node.names:
                names = alias.name.split(".")
                if names[0] == PACKAGE.name:
                    found.add(_module_file(names[1:]))
        elif isinstance(node, ast.ImportFrom):
            base = _from_names(node, package)
            if base is not None:
                for alias in node.names:
                    found.add(_module_file(base + [alias.name]) or _module_file(base))
    found.discard(None)
    return found


def generator_sources(
    read: Reader = Path.read_text, imports: Callable[[Path, str], set[Path]] = imported_files
) -> dict[Path, str]:
    """Every file that feeds the generated module, with its text (``read`` gives the texts,
    ``imports`` what a file imports: :func:`imported_files`, or an :class:`ImportMemo`'s)."""
    sources: dict[Path, str] = {}
    todo = sorted(HERE.glob("*.py"))
    while todo:
        path = todo.pop()
        if path not in sources:
            sources[path] = read(path)
            todo += sorted(imports(path, sources[path]) - sources.keys())
    return sources


def _layout() -> str:
    """A hash of the package's module files (what :func:`imported_files` looks for besides
    the text it is given): a file added, moved or removed makes every memo out of date."""
    names = []
    for folder, subfolders, files in os.walk(PACKAGE):
        subfolders[:] = sorted(d for d in subfolders if d != "__pycache__")
        rel = Path(folder).relative_to(PACKAGE).as_posix()
        names += [f"{rel}/{f}" for f in sorted(files) if f.endswith(".py")]
    return hashlib.sha256("\n".join([PACKAGE.name, *names]).encode()).hexdigest()


def _seal(layout: str, imports) -> str:
    return hashlib.sha256(json.dumps([layout, imports], sort_keys=True).encode()).hexdigest()


class ImportMemo:
    """:func:`imported_files` of each file, kept in the file ``path`` between processes: by the
    file's path below the package and the SHA-256 of its text, for the package's layout. An
    unreadable, damaged or out-of-date memo is an empty one; one that cannot be written is not
    kept; a seal (a hash of the layout and the entries) tells a damaged one. :meth:`save` keeps
    the entries used since it was read."""

    def __init__(self, path: Path):
        self.path = path
        self.layout = _layout()
        self.known: dict[str, list[str]] = {}
        self.used: dict[str, list[str]] = {}
        with contextlib.suppress(OSError, ValueError, TypeError, KeyError, AttributeError):
            data = json.loads(path.read_text())
            imports = data["imports"]
            if isinstance(imports, dict) and data["seal"] == _seal(self.layout, imports):
                self.known = imports  # neither damaged nor of another layout

    def __call__(self, path: Path, text: str) -> set[Path]:
        key = f"{path.relative_to(PACKAGE).as_posix()}:{hashlib.sha256(text.encode()).hexdigest()}"
        names = self.known.get(key)
        if not (isinstance(names, list) and all(isinstance(n, str) for n in names)):
            names = sorted(p.relative_to(PACKAGE).as_posix() for p in imported_files(path, text))
        self.used[key] = names
        return {PACKAGE / n for n in names}

    def save(self) -> None:
        if self.used == self.known:
            return
        data = {"imports": self.used, "seal": _seal(self.layout, self.used)}
        text = json.dumps(data, indent=0, sort_keys=True)
        with contextlib.suppress(OSError):
            self.path.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(self.path, lambda tmp: Path(tmp).write_text(text))


def package_digest(memo: Path | None = None) -> str:
    """The hash of every file that feeds the generated module, their imports read from (and
    kept in) the memo file ``memo``, if given (:class:`ImportMemo`)."""
    if memo is None:
        return _digest(generator_sources())
    imports = ImportMemo(memo)
    digest = _digest(generator_sources(imports=imports))
    imports.save()
    return digest


def _digest(sources: dict[Path, str]) -> str:
    h = hashlib.sha256()
    for path in sorted(sources):
        for part in (path.relative_to(PACKAGE).as_posix(), sources[path]):
            h.update(part.encode())
            h.update(b"\0")
    return h.hexdigest()


#: The memo of the package's imports, in the cache folder (:class:`ImportMemo`).
IMPORTS_FILE = "imports.json"


@cache
def _package_digest() -> str:
    return package_digest(cache_dir() / "models" / IMPORTS_FILE)


def cache_key(model_source: str, read: Reader | None = None) -> str:
    """The key of the generated module of the model whose source (a built-in model's file, or a
    ``VehicleModel``'s fingerprint) is ``model_source``. ``read`` replaces ``Path.read_text``
    for the package's files (the tests alter one file's text with it)."""
    files = _package_digest() if read is None else _digest(generator_sources(read))
    h = hashlib.sha256()
    for part in (numba.__version__, model_source, files):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:16]
