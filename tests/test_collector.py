"""ur3dq/collector.py: the cyclic collector is paused inside and restored as it was, also on errors and when
nested; a paused function still gives its result."""
import gc

import pytest

from ur3dq.collector import cyclic_gc_paused


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
