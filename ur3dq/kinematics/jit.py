"""The compiled kinematics kernels' plumbing: one decorator, numba's on-disk cache, and the first-use notice.

Kernels are plain Python functions on floats and float arrays, compiled with ``numba.njit(cache=True)``. Keep them
in modules of their own (numba caches a kernel beside its source file) and import those where a kernel is called,
never at the top of a module that commands without kinematics import (``ur3dq --help``, ``poses list``)::

    from ur3dq.kinematics.jit import kernel

    @kernel
    def hypotenuse(x: float, y: float) -> float:
        return (x * x + y * y) ** 0.5

A kernel may call only numpy, ``math`` and other kernels; numba's ``np.linalg`` needs scipy, which the package does
not depend on, so write small solves out.

With ``NUMBA_DISABLE_JIT=1`` they run as the Python they are (the tests compare both). Only the modules that define
kernels import numba, so commands that need no kinematics never load it. numba keeps the machine code in the
package's ``__pycache__``, or in a per-user cache directory where the package directory is not writable; where
neither can be written the kernels compile in memory, once per process.

The first use after an install (or a change of the kernels' sources) compiles every kernel: ``warm_once`` says so in
one line on stderr and leaves a marker beside the cache, so later processes load the cache silently.
``python -m ur3dq.kinematics.jit --warm`` compiles ahead of time (``make test`` and ``make demo`` run it before their
workers start).
"""
from __future__ import annotations

import argparse
import hashlib
import importlib
import os
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar, cast

F = TypeVar("F", bound=Callable[..., Any])

#: Modules whose kernels ``--warm`` compiles; each defines ``kernels()``, which compiles them (once per cache) or
#: loads them.
KERNEL_MODULES = ("ur3dq.kinematics.ur_ik", "ur3dq.kinematics.dls")
#: Roughly how long the first compilation takes on a 2-core machine (shown in the notice).
COMPILE_SECONDS = 30


def interpreted() -> bool:
    """Whether kernels run as the Python they are: numba's own switch, NUMBA_DISABLE_JIT=1, honoured here without
    importing numba (one pose solves in milliseconds that way, where loading numba and its cache takes half a
    second of CPU)."""
    return os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0")


def kernel(function: F) -> F:
    """``function`` compiled with numba (nopython, IEEE arithmetic: no fastmath, a division by zero gives inf or NaN
    as in numpy; cached on disk where a cache directory is writable). Write kernels that never divide by zero: the
    interpreted function would raise there. Under ``NUMBA_DISABLE_JIT=1`` the result is the function itself."""
    if interpreted():
        return function
    import numba  # only where kernels are compiled: the one import of numba in ur3dq

    try:
        compiled = numba.njit(cache=True, error_model="numpy")(function)
    except RuntimeError:   # numba found no writable cache directory: compile in memory, once per process
        compiled = numba.njit(cache=False, error_model="numpy")(function)
    _KERNELS.append(compiled)
    return cast(F, compiled)


_KERNELS: list[Any] = []


def _cache_directories(sources: tuple[str, ...]) -> dict[str, Path]:
    """Where numba caches the kernels defined in each of ``sources`` (those with a cache: none under
    NUMBA_DISABLE_JIT or where no directory is writable)."""
    directories: dict[str, Path] = {}
    for compiled in _KERNELS:
        cache = getattr(compiled, "_cache", None)   # numba's per-function cache (not part of its documented API)
        source = compiled.py_func.__code__.co_filename
        if cache is not None and cache.cache_path is not None and source in sources:
            directories.setdefault(source, Path(cache.cache_path))
    return directories


def warm_once(label: str, sources: tuple[str, ...], warm: Callable[[], None]) -> None:
    """Run ``warm`` (which calls every kernel of ``sources`` once) unless this cache has compiled these very sources
    already; when it runs, one line on stderr says why the call is slow. Before it, the cache files of these sources
    are removed: numba checks a kernel's own file only, not the files of the kernels (and constants) it uses."""
    if interpreted():
        return
    import numba

    directories = _cache_directories(sources)
    digest = hashlib.sha256(numba.__version__.encode())
    for source in sources:
        digest.update(Path(source).read_bytes())
    first = next((directories[source] for source in sources if source in directories), None)   # not import order
    marker = None if first is None else first / f"ur3dq-{label}-{digest.hexdigest()[:16]}.compiled"
    if marker is not None and marker.exists():
        return
    print(f"compiling kinematics kernels, once (about {COMPILE_SECONDS} s)…", file=sys.stderr, flush=True)
    for source, directory in directories.items():
        for stale in directory.glob(f"{Path(source).stem}.*.nb[ic]"):
            stale.unlink(missing_ok=True)
    warm()
    if marker is not None:
        for stale in marker.parent.glob(f"ur3dq-{label}-*.compiled"):
            stale.unlink(missing_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=marker.parent, delete=False) as written:
            written.write(f"{time.time():.0f}\n")
        os.replace(written.name, marker)


def main(argv: list[str] | None = None) -> int:
    """``python -m ur3dq.kinematics.jit --warm``: compile (or load) every kernel now."""
    parser = argparse.ArgumentParser(description="Compile ur3dq's kinematics kernels into numba's cache.")
    parser.add_argument("--warm", action="store_true", help="compile every kernel now (no-op when cached)")
    arguments = parser.parse_args(argv)
    if arguments.warm:
        for name in KERNEL_MODULES:
            importlib.import_module(name).kernels()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
