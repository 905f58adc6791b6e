"""Waiting on controller time in tests: a number of control cycles, instead of a fixed wall-clock sleep.

A test that must show that nothing happens during a window (a paused program, a held value) waits for the
controller to publish that many cycles: on a loaded machine the window stays the same in controller time.
"""


def wait_cycles(controller, count, timeout=10.0):
    """Return the snapshot once `count` more control cycles have been published; AssertionError after `timeout` s."""
    start = controller.state().cycle
    state = controller.state()
    while state.cycle < start + count:
        state = controller.wait_cycle(state.cycle, timeout)
        if state.cycle == start and not controller.running:
            raise AssertionError("the controller's loop is not running")
    return state
