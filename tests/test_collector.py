"""ur3dq/collector.py: the cyclic collector is paused inside and restored as it was, also on errors and when
nested; a paused function still gives its result; what a command's block built is left out of later collections."""
import gc

import pytest

from ur3dq.collector import built_to_last, cyclic_gc_paused


@pytest.fixture
def collector_on():
    was = gc.isenabled()
    gc.enable()
    yield
    (gc.enable if was else gc.disable)()


def test_the_collector_is_off_inside_and_on_again_after(collector_on):
    with cyclic_gc_paused():
        assert not gc.isenabled()
        with cyclic_gc_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()   # the inner pause leaves it to the outer one
    assert gc.isenabled()


def test_an_error_inside_restores_the_collector(collector_on):
    with pytest.raises(KeyError):
        with cyclic_gc_paused():
            raise KeyError("x")
    assert gc.isenabled()


def test_a_collector_that_was_off_stays_off():
    was = gc.isenabled()
    gc.disable()
    try:
        with cyclic_gc_paused():
            pass
        assert not gc.isenabled()
    finally:
        (gc.enable if was else gc.disable)()


def test_as_a_decorator_it_pauses_each_call(collector_on):
    @cyclic_gc_paused()
    def inside():
        return gc.isenabled()

    assert inside() is False and inside() is False and gc.isenabled()


class _Node:
    pass


def test_what_a_commands_block_built_is_never_examined_again(collector_on):
    examined = []

    def count(phase, info):
        if phase == "stop":
            examined.append(info["collected"])

    kept = []
    try:
        with built_to_last():
            assert not gc.isenabled()
            for _ in range(1000):   # cycles the block still holds: a collection would walk them
                node = _Node()
                node.self = node
                kept.append(node)
        assert gc.isenabled() and gc.get_freeze_count() >= 1000
        frozen = gc.get_freeze_count()
        gc.collect()   # whatever else was garbage
        gc.callbacks.append(count)
        kept.clear()   # garbage cycles now, but frozen: a full collection leaves them be
        gc.collect()
        assert gc.get_freeze_count() == frozen and examined == [0]
    finally:
        if count in gc.callbacks:
            gc.callbacks.remove(count)
        gc.unfreeze()
        gc.collect()
    with pytest.raises(KeyError):   # an error inside still restores the collector
        with built_to_last():
            raise KeyError("x")
    gc.unfreeze()
    assert gc.isenabled()
