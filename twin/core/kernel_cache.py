"""numba's on-disk cache of the project's kernels, stale whenever any kernel's source changes.

numba keeps a compiled ``@njit(cache=True)`` function next to its source and reuses it while
*that file* is unchanged: a kernel that calls a kernel of another file (the exact chain calls
the scattering kernel; the window grid, the chain's Fresnel factors) keeps running the callee
it was compiled with after the callee's file has changed: a silently wrong number after a
``git pull`` or an edit (numba's known limit: numba/numba#8396, not merged). Measured here: with
``column_kernel.py`` changed and ``chain_kernel.py`` not, the chain's cached frame stayed the old
one bit for bit until the cache was deleted.

So every kernel of the project is cached under a stamp of *all* of the project's files that use
numba: its own file's numba stamp and a digest of the others' contents. Changing any of them
recompiles every kernel once (a minute or so on two cores, then cached again); changing a file
without numba recompiles nothing. A constant that a kernel reads as a global from a file
without numba is not covered: kernels take such values as arguments.

:func:`install` registers the stamp with numba (its cache locators, the classes numba asks
where a function's cache lives and how fresh it is). numba picks a function's locator when the
decorator runs, so the project's kernels are decorated with this module's :func:`njit`, which
installs first (``tests/test_kernel_cache.py`` holds every kernel module to it).
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from pathlib import Path
from typing import Any

#: The project's packages whose kernels are cached together (the folders next to this package).
PACKAGES = ("twin", "sensors", "scenarios")

_ROOTS: tuple[Path, ...] = ()
_DIGEST: str | None = None


def _default_roots() -> tuple[Path, ...]:
    top = Path(__file__).resolve().parents[2]
    return tuple(top / p for p in PACKAGES if (top / p).is_dir())


def digest() -> str:
    """sha256 of every ``*.py`` under the roots that mentions numba or njit: path and contents."""
    global _DIGEST
    if _DIGEST is None:
        h = hashlib.sha256()
        for root in _ROOTS:
            for path in sorted(root.rglob("*.py")):
                data = path.read_bytes()
                if b"numba" in data or b"njit" in data:
                    h.update(str(path.relative_to(root.parent)).encode())
                    h.update(hashlib.sha256(data).digest())
        _DIGEST = h.hexdigest()
    return _DIGEST


def _inside(py_file: str) -> bool:
    p = Path(py_file).resolve()  # (the roots are resolved too: a checkout behind a link)
    return any(p.is_relative_to(r) for r in _ROOTS)


def _project_locator(base: type) -> type:
    """A subclass of numba's ``base`` locator: the project's files only, the digest in the stamp."""

    class ProjectLocator(base):  # type: ignore[misc, valid-type]
        def get_source_stamp(self) -> Any:
            return (super().get_source_stamp(), digest())

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if not _inside(py_file):
                return None
            return super().from_function(py_func, py_file)

    ProjectLocator.__name__ = ProjectLocator.__qualname__ = f"Project{base.__name__}"
    ProjectLocator._auv_twin = True  # type: ignore[attr-defined]
    return ProjectLocator


def install(roots: Iterable[Path | str] | None = None) -> None:
    """Cache the kernels under ``roots`` (default: :data:`PACKAGES`) with the joint stamp.

    Each of numba's source-file locators gets a project twin ahead of it in numba's list, so
    that ``NUMBA_CACHE_DIR``, the in-tree ``__pycache__`` and the user-wide fallback keep their
    order. Idempotent; a call with other roots replaces them (the tests' temporary packages).
    """
    global _ROOTS, _DIGEST
    from numba.core import caching

    new = tuple(Path(r).resolve() for r in roots) if roots is not None else _default_roots()
    if new != _ROOTS:
        _ROOTS, _DIGEST = new, None
    # numba's list of locators, asked in order (numba ≥ 0.62 names the class CacheImpl). A list
    # given in NUMBA_CACHE_LOCATOR_CLASSES replaces it: a user who sets that keeps numba's stamps.
    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    classes = impl._locator_classes
    if any(getattr(c, "_auv_twin", False) for c in classes):
        return
    out = []
    for c in classes:
        if issubclass(c, caching._SourceFileBackedLocatorMixin):
            out.append(_project_locator(c))
        out.append(c)
    classes[:] = out


def njit(*args: Any, **kwargs: Any) -> Any:
    """``numba.njit``, after :func:`install`: the project's kernels' decorator."""
    import numba

    if not _ROOTS:
        install()
    return numba.njit(*args, **kwargs)
