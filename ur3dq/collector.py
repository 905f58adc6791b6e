"""Python's cyclic garbage collector paused while a big store is parsed, planned or checked, and (for a command's
process only) what such a step built kept out of the collector's way.

Those steps build 10⁵ acyclic objects that live on (poses, plan steps, path segments, reports); reference counting
frees whatever they drop. Every collection the allocations trigger walks all the objects built so far, so with the
collector on, the collections cost as much as the work: on bench_store.py's 93,587 poses, parsing takes 1.7 s of CPU
without them and 3.0 s with them, and the path check 0.95 s against 1.4 s.
"""
from __future__ import annotations

import contextlib
import gc


@contextlib.contextmanager
def cyclic_gc_paused():
    """The collector off inside (a `with` block, or as a decorator), restored as it was, also when the body raises.
    Nested pauses keep it off until the outermost ends."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


@contextlib.contextmanager
def built_to_last():
    """For a command-line process, not a library: the collector paused inside (cyclic_gc_paused), then every
    object alive (what the block built among them) moved to the collector's permanent generation (gc.freeze),
    which collections never examine.

    A command plans a big store once and keeps the plan until it exits or runs it. When the collector resumes,
    its next collections examine every object the block built, ~10⁶ for 10⁵ poses: 0.15 s of CPU for nothing
    (bench_store.py's plans, measured with gc.callbacks). The price: a reference cycle among those objects that is
    or becomes garbage is never freed; a command's process can afford that, a long-lived program cannot."""
    with cyclic_gc_paused():
        try:
            yield
        finally:
            gc.freeze()
