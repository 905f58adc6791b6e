"""The one way the kinematics compiles its kernels: :func:`kernel`, numba's ``njit`` with its on-disk cache.

numba is imported by the first :func:`kernel` call, so only a module that defines kernels pays for it: keep
kernels in their own modules (``*_kernels.py``) and import those where a kernel is called, never at the top of a
module that commands without kinematics import (``ur3dq --help``, ``poses list``).

A kernel is plain Python: with ``NUMBA_DISABLE_JIT=1`` in the environment numba returns it unchanged, which is how
the tests compare the interpreted reference with the compiled code.

Example (in a module of its own: numba caches a kernel beside its source file)::

    from ur3dq.kinematics.jit import kernel

    @kernel
    def twice(x: float) -> float:
        return 2.0 * x
"""
from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar, cast

F = TypeVar("F", bound=Callable[..., object])


def kernel(function: F) -> F:
    """``function`` compiled by numba in nopython mode, cached on disk (the package's ``__pycache__``).

    A kernel may call only numpy, ``math`` and other kernels; numba's ``np.linalg`` needs scipy, which the package
    does not depend on, so write small solves out.
    """
    import numba  # deferred: importing this module must not import numba

    return cast(F, numba.njit(cache=True)(function))
