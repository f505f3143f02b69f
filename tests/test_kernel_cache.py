"""numba's cached kernels go stale with any kernel file of the project (twin/core/kernel_cache.py).

numba reuses a cached function while its own file is unchanged, even when a function it calls,
in another file, has changed. The project's kernels are cached under a stamp of all its numba
files, so a change to any of them recompiles every kernel.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

import numba
import pytest

from twin.core import kernel_cache

ROOT = Path(__file__).resolve().parents[1]


def _kernel_modules() -> list[str]:
    out = []
    for pkg in kernel_cache.PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            if "import njit" in path.read_text() and path.name != "kernel_cache.py":
                out.append(".".join(path.relative_to(ROOT).with_suffix("").parts))
    return out


def test_every_kernel_module_takes_njit_from_the_kernel_cache():
    """So that a new kernel cannot bypass the joint stamp."""
    bad = []
    for pkg in kernel_cache.PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            text = path.read_text()
            if "from numba import" in text and "njit" in text.split("from numba import")[1][:60]:
                bad.append(str(path.relative_to(ROOT)))
            if "numba.njit(" in text and path.name != "kernel_cache.py":
                bad.append(str(path.relative_to(ROOT)))
    assert not bad, bad


def test_every_cached_kernel_has_the_projects_locator():
    modules = _kernel_modules()
    assert len(modules) >= 15
    cached = 0
    for name in modules:
        mod = importlib.import_module(name)
        for obj in vars(mod).values():
            if isinstance(obj, numba.core.registry.CPUDispatcher) and obj._cache is not None:
                impl = getattr(obj._cache, "_impl", None)
                if impl is None:  # a NullCache: not cached
                    continue
                assert getattr(impl.locator, "_auv_twin", False), (name, obj.__name__)
                cached += 1
    assert cached >= 30, cached


_A = """
from {imp} import njit

@njit(cache=True)
def f():
    return {value}
"""

_B = """
from {imp} import njit
from {pkg}.a import f

@njit(cache=True)
def g():
    return f() + 10
"""

_RUN = """
import sys
sys.path.insert(0, {tmp!r})
from twin.core import kernel_cache
kernel_cache.install([{fixed!r}])
from plain.b import g as g_plain
from fixed.b import g as g_fixed
print(g_plain(), g_fixed())
"""


def test_a_changed_callee_recompiles_its_callers_with_the_joint_stamp(tmp_path):
    """Two temporary packages, one on numba's own cache, one on the project's: edit a callee."""
    for pkg, imp in (("plain", "numba"), ("fixed", "twin.core.kernel_cache")):
        (tmp_path / pkg).mkdir()
        (tmp_path / pkg / "__init__.py").write_text("")
        (tmp_path / pkg / "a.py").write_text(_A.format(imp=imp, value=1))
        (tmp_path / pkg / "b.py").write_text(_B.format(imp=imp, pkg=pkg))
    script = _RUN.format(tmp=str(tmp_path), fixed=str(tmp_path / "fixed"))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("NUMBA_CACHE_DIR", None)

    def run() -> list[int]:
        out = subprocess.run(
            [sys.executable, "-c", script], capture_output=True, text=True, env=env, cwd=tmp_path
        )
        assert out.returncode == 0, out.stderr
        return [int(x) for x in out.stdout.split()]

    assert run() == [11, 11]  # compiled and cached
    assert run() == [11, 11]  # from the cache
    for pkg, imp in (("plain", "numba"), ("fixed", "twin.core.kernel_cache")):
        (tmp_path / pkg / "a.py").write_text(_A.format(imp=imp, value=2))
    # numba alone keeps g's stale f (its own file did not change); the joint stamp recompiles.
    assert run() == [11, 12]
    assert list((tmp_path / "fixed" / "__pycache__").glob("b.g-*.nbi"))  # cached, not bypassed


def test_the_digest_covers_numba_files_only(tmp_path):
    (tmp_path / "k").mkdir()
    (tmp_path / "k" / "kern.py").write_text("from twin.core.kernel_cache import njit\n")
    (tmp_path / "k" / "plain.py").write_text("x = 1\n")
    old_roots = kernel_cache._ROOTS
    try:
        kernel_cache.install([tmp_path / "k"])
        d0 = kernel_cache.digest()
        (tmp_path / "k" / "plain.py").write_text("x = 2\n")
        kernel_cache.install([tmp_path])  # other roots: the digest is recomputed …
        kernel_cache.install([tmp_path / "k"])
        assert kernel_cache.digest() == d0  # … and a file without numba does not enter it
        (tmp_path / "k" / "kern.py").write_text("from twin.core.kernel_cache import njit  # new\n")
        kernel_cache.install([tmp_path])
        kernel_cache.install([tmp_path / "k"])
        assert kernel_cache.digest() != d0
    finally:
        kernel_cache.install(old_roots or None)


@pytest.mark.parametrize("name", ["sensors.polarimeter.chain_kernel", "twin.onboard.eskf_kernels"])
def test_the_projects_stamp_holds_the_digest(name):
    mod = importlib.import_module(name)
    disp = next(
        o
        for o in vars(mod).values()
        if isinstance(o, numba.core.registry.CPUDispatcher)
        and o._cache is not None
        and getattr(o._cache, "_impl", None) is not None
    )
    stamp = disp._cache._impl.locator.get_source_stamp()
    assert stamp[1] == kernel_cache.digest() and len(stamp[1]) == 64
