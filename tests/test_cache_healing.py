"""A damaged kernel cache heals itself: the damage is reported in one line, the entry rebuilt,
and the command gives the right answer. Each case runs on a copy of the warm cache of the
unicycle's kernels (never the real one)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from tests.test_cli import cli_env

import leapfrog_planner
from leapfrog_planner._cache import cache_dir
from leapfrog_planner.compiled.kernels import load_kernels

CASE1 = 10.323202  # paper case 1's optimum


@pytest.fixture(scope="module")
def warm(tmp_path_factory) -> Path:
    """The unicycle's generated module, numba's files of it and the tableaux, copied."""
    module = Path(load_kernels("unicycle").__file__)
    subprocess.run(  # make sure every kernel the solve uses is in the disk cache
        [sys.executable, "-m", "leapfrog_planner.cli", "warmup", "unicycle"],
        env=cli_env(), capture_output=True, check=True, timeout=600,
    )  # fmt: skip
    root = tmp_path_factory.mktemp("warm-cache")
    (root / "models" / "__pycache__").mkdir(parents=True)
    shutil.copy2(module, root / "models" / module.name)
    for f in module.parent.glob(f"__pycache__/{module.stem}.*"):
        shutil.copy2(f, root / "models" / "__pycache__" / f.name)
    for f in cache_dir().glob("tableaux-*.npz"):
        shutil.copy2(f, root / f.name)
    return root


def _damage(path: Path, how: str) -> None:
    data = path.read_bytes()
    if how == "empty":
        path.write_bytes(b"")
    elif how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "flipped":
        b = bytearray(data)
        b[len(b) // 2] ^= 0xFF
        path.write_bytes(bytes(b))
    else:  # random bytes of the same length
        path.write_bytes(os.urandom(max(len(data), 64)))


def _target(cache: Path, what: str) -> Path:
    if what == "module":
        return next((cache / "models").glob("*.py"))
    if what == "tableaux":
        return next(cache.glob("tableaux-*.npz"))
    return sorted((cache / "models" / "__pycache__").glob(f"*shoot_newton*.{what}"))[0]


#: Each but the last recompiles the kernels (20-40 s): one damage per kind of file (an empty
#: index and a truncated nbc heal as these do: all 11 kinds were checked by hand).
DAMAGES = [
    ("module", "truncated"),
    ("nbi", "random"),
    ("nbc", "flipped"),
    ("tableaux", "truncated"),
]


def _healed(
    warm: Path, folder: Path, what: str, how: str
) -> tuple[subprocess.CompletedProcess, Path]:
    folder.mkdir()
    cache = folder / "cache"
    shutil.copytree(warm, cache)
    _damage(_target(cache, what), how)
    env = {**cli_env(), "LEAPFROG_CACHE_DIR": str(cache)}
    p = subprocess.run(
        [sys.executable, "-m", "leapfrog_planner.cli", "solve", "paper-case-1", "--quiet",
         "--json", "r.json"],
        cwd=folder, env=env, capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    return p, folder / "r.json"


@pytest.fixture(scope="module")
def healed(warm, tmp_path_factory) -> dict:
    """Every damage of :data:`DAMAGES`, healed by a solve in a process of its own, two at a
    time (the recompiles take most of the time)."""
    from concurrent.futures import ThreadPoolExecutor

    root = tmp_path_factory.mktemp("healed")
    with ThreadPoolExecutor(2) as pool:
        futures = {d: pool.submit(_healed, warm, root / f"{d[0]}-{d[1]}", *d) for d in DAMAGES}
        return {d: f.result() for d, f in futures.items()}


@pytest.mark.parametrize("what, how", DAMAGES)
def test_a_damaged_cache_entry_is_reported_once_and_rebuilt(healed, what, how):
    p, result = healed[what, how]
    assert p.returncode == 0, p.stderr[-2000:]
    lines = p.stderr.strip().splitlines()
    assert len(lines) <= 1 and all(line.startswith("warning: ") for line in lines), p.stderr
    assert json.loads(result.read_text())["cost"] == pytest.approx(CASE1, rel=1e-6)


def _read_only_mounts_work() -> bool:
    if shutil.which("unshare") is None or os.geteuid() != 0:
        return False
    script = 'mount --bind -o ro "$1" "$1" && ! touch "$1/.probe" 2>/dev/null'
    probe = subprocess.run(
        ["unshare", "-m", "--propagation", "private", "sh", "-c", script, "sh", "/tmp"],
        capture_output=True,
    )
    return probe.returncode == 0


@pytest.mark.skipif(not _read_only_mounts_work(), reason="needs root and read-only bind mounts")
def test_a_warm_read_only_installation_and_cache_are_used_as_they_are(warm, tmp_path):
    """The package, the cache and the home folder read-only (as on some clusters): before, numba
    could not define a cached function and the import failed; now the warm compiled files are
    copied to a temporary folder and used there: nothing is compiled again."""
    package = Path(leapfrog_planner.__file__).resolve().parent
    home, tmp = tmp_path / "home", tmp_path / "tmp"
    home.mkdir()
    tmp.mkdir()
    script = (
        'for d in "$PACKAGE" "$LEAPFROG_CACHE_DIR" "$HOME"; do mount --bind -o ro "$d" "$d"; done\n'
        'exec "$@"'
    )
    env = {**cli_env(), "PACKAGE": str(package), "LEAPFROG_CACHE_DIR": str(warm),
           "HOME": str(home), "TMPDIR": str(tmp)}  # fmt: skip
    env.pop("XDG_CACHE_HOME", None)
    env.pop("NUMBA_CACHE_DIR", None)
    p = subprocess.run(
        ["unshare", "-m", "--propagation", "private", "sh", "-c", script, "sh",
         sys.executable, "-m", "leapfrog_planner.cli", "solve", "paper-case-1", "--quiet",
         "--json", str(tmp / "r.json")],
        env=env, capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert p.returncode == 0, p.stderr[-2000:]
    assert json.loads((tmp / "r.json").read_text())["cost"] == pytest.approx(CASE1, rel=1e-6)
    originals = {f.name: f.read_bytes() for f in [*package.rglob("*.nbi"), *warm.rglob("*.nbi")]}
    copies = list(tmp.rglob("*.nbi"))
    assert copies, "nothing was copied from the read-only cache"
    recompiled = [f.name for f in copies if originals.get(f.name) != f.read_bytes()]
    assert not recompiled, f"compiled again: {recompiled[:5]}"


def test_the_fallback_folder_is_private_to_the_user(tmp_path, monkeypatch):
    """Where the cache cannot be written, compiled code goes to a folder of the temporary
    directory that only this user may write or enter (code found there is imported)."""
    import stat
    import tempfile

    from leapfrog_planner import _cache

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.setenv("LEAPFROG_CACHE_DIR", "/proc/no-such-folder")
    d = _cache.writable_dir("models")
    root = tmp_path / f"leapfrog-planner-{os.getuid()}"
    assert d == root / "models"
    assert stat.S_IMODE(root.stat().st_mode) == 0o700
    assert _cache.writable_dir("models") == d  # the same folder next time: compiled once


def test_a_fallback_folder_planted_by_another_user_is_not_used(tmp_path, monkeypatch):
    """The attack: another user creates the predictable folder first (open to all, or their
    own) with a module in it. It is neither used nor imported: a fresh private folder is."""
    import stat
    import tempfile

    from leapfrog_planner import _cache

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    planted = tmp_path / f"leapfrog-planner-{os.getuid()}"
    (planted / "models").mkdir(parents=True)
    (planted / "models" / "unicycle.py").write_text("raise SystemExit('planted code ran')\n")
    planted.chmod(0o777)
    fresh = _cache.private_temp_root()
    assert fresh != planted and stat.S_IMODE(fresh.stat().st_mode) == 0o700
    assert not any(fresh.iterdir())
    if os.geteuid() == 0:  # a folder of another owner, however private
        planted.chmod(0o700)
        os.chown(planted, 65534, 65534)
        assert _cache.private_temp_root() != planted
    link = tmp_path / "elsewhere"
    link.mkdir(mode=0o700)
    planted.rename(tmp_path / "moved")
    planted.symlink_to(link)  # a link to a private folder is not the folder itself
    assert _cache.private_temp_root() != planted


@pytest.mark.parametrize(
    "damage",
    ["", "MODEL_NAME = 'x'\n", "cut", "edited", "seal only"],
)
def test_a_generated_module_is_imported_only_with_its_seal(tmp_path, damage):
    """A generated module's last line seals the text above it: an empty, cut, edited or
    hand-written module is refused (and so built again), never imported."""
    from leapfrog_planner.compiled.kernels import DamagedModule, _check_integrity, sealed

    text = sealed("MODEL_NAME = 'unicycle'\nSTATES = ('x', 'y', 'theta')\n")
    path = tmp_path / "m.py"
    path.write_text(text)
    _check_integrity(path)  # the sealed text passes
    bad = {
        "cut": text[: len(text) // 2],
        "edited": text.replace("unicycle", "planted"),
        "seal only": text.splitlines(keepends=True)[-1],
    }.get(damage, damage)
    path.write_text(bad)
    with pytest.raises(DamagedModule):
        _check_integrity(path)


PROBE = """
from leapfrog_planner._jit import njit


@njit(cache=True)
def plus_one(x):
    return x + 1


@njit(cache=True)
def times(x, y):
    return x * y
"""

RUN = "import lfp_probe as p; print(p.plus_one(1.0), p.plus_one(2), p.times(2.0, 3.0))"


def _probe(folder: Path) -> subprocess.CompletedProcess:
    package = Path(leapfrog_planner.__file__).parents[1]
    env = {**cli_env(), "PYTHONPATH": os.pathsep.join([str(folder), str(package)])}
    env.pop("NUMBA_CACHE_DIR", None)
    return subprocess.run([sys.executable, "-c", RUN], env=env, capture_output=True, text=True,
                          cwd=folder, timeout=300)  # fmt: skip


def _swap(a: Path, b: Path) -> None:
    data = a.read_bytes()
    a.write_bytes(b.read_bytes())
    b.write_bytes(data)


def test_numba_cache_files_swapped_are_said_compiled_again_and_healed(tmp_path):
    """numba loads whatever file its index names: two data files swapped (of two functions, or
    two signatures of one) would run the wrong machine code on every run (a ``TypeError`` deep in
    numba, or wrong numbers). The load is checked: the run says so, computes the right numbers,
    and writes the files anew, so the next run is quiet."""
    (tmp_path / "lfp_probe.py").write_text(PROBE)
    first = _probe(tmp_path)
    assert first.returncode == 0, first.stderr
    assert first.stdout.split() == ["2.0", "3", "6.0"]
    files = {f.name.split("-")[0]: f for f in (tmp_path / "__pycache__").glob("*.nbc")}
    plus = sorted((tmp_path / "__pycache__").glob("lfp_probe.plus_one-*.nbc"))
    assert len(plus) == 2  # plus_one of a float and of an int
    _swap(files["lfp_probe.times"], plus[0])
    _swap(plus[0], plus[1])
    damaged = _probe(tmp_path)
    assert damaged.returncode == 0, damaged.stderr
    assert damaged.stdout.split() == ["2.0", "3", "6.0"]
    said = [ln for ln in damaged.stderr.splitlines() if ln]
    assert said and all("holds other code (a damaged cache)" in ln for ln in said), said
    assert any("lfp_probe.times" in ln for ln in said)
    healed = _probe(tmp_path)
    assert (healed.returncode, healed.stdout.split(), healed.stderr) == (0, ["2.0", "3", "6.0"], "")
