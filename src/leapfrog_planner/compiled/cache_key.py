"""The cache key of a model's generated kernel module: a hash of everything that shapes it.

numba's disk cache keys a function by its own file and does not notice a change in a function
that a cached function calls (the templates call the penalty, which numba caches apart), so the
key of the generated module must change with every file whose code is compiled into it or
shapes its text. Those files are found, not listed: every module of this subpackage (the
generator, the templates, the records, the loader) and, transitively, every module of the
package that one of them imports, anywhere in its text (imports inside functions included),
read with ``ast``. The key hashes their paths and texts, numba's version and the model's own
source. Finding them reads and parses a few files and imports nothing: a warm start never loads
SymPy.
"""

from __future__ import annotations

import ast
import hashlib
from collections.abc import Callable
from functools import cache
from pathlib import Path

import numba

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


def generator_sources(read: Reader = Path.read_text) -> dict[Path, str]:
    """Every file that feeds the generated module, with its text (``read`` gives the texts)."""
    sources: dict[Path, str] = {}
    todo = sorted(HERE.glob("*.py"))
    while todo:
        path = todo.pop()
        if path not in sources:
            sources[path] = read(path)
            todo += sorted(imported_files(path, sources[path]) - sources.keys())
    return sources


def _digest(sources: dict[Path, str]) -> str:
    h = hashlib.sha256()
    for path in sorted(sources):
        for part in (path.relative_to(PACKAGE).as_posix(), sources[path]):
            h.update(part.encode())
            h.update(b"\0")
    return h.hexdigest()


@cache
def _package_digest() -> str:
    return _digest(generator_sources())


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
