"""Polling for tests: wait until a condition holds, with a deadline, instead of sleeping a fixed time."""
import time


def wait_for(predicate, timeout=3.0, interval=0.01):
    """Poll `predicate` every `interval` s until it is true (True) or `timeout` s pass (its last value)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval)
    return predicate()
