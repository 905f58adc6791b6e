"""Ctrl-C taken at the driver's polls (ur3dq.robot.interrupts): never inside a lock, always at the next poll.

The stress case is the hang it prevents, reproduced: a main thread that drains a queue another thread fills, and
a SIGINT sprayed at it at random instants. Raised anywhere, one lands now and then inside the queue's lock just
after it was taken; the clean-up's own drain of that queue then waits forever (about 1 run in 4 of this loop
without the deferral, on a 2-core machine: 100 runs then hang with certainty).
"""
import signal
import subprocess
import sys
import textwrap

import pytest

from ur3dq.robot import interrupts


class Polite(Exception):
    """What this test's own SIGTERM handler raises, as the CLI's raises Terminated."""


@pytest.fixture
def handlers():
    """SIGINT raising KeyboardInterrupt and SIGTERM raising Polite, as in the CLI; the test runner's put back."""
    def polite(signum, frame):
        raise Polite(signum)

    previous = {signal.SIGINT: signal.signal(signal.SIGINT, signal.default_int_handler),
                signal.SIGTERM: signal.signal(signal.SIGTERM, polite)}
    yield polite
    for signum, handler in previous.items():
        signal.signal(signum, handler)


def test_a_signal_in_the_block_is_raised_at_the_next_poll_and_the_handlers_come_back(handlers):
    reached = []
    with pytest.raises(KeyboardInterrupt):
        with interrupts.at_polls():
            signal.raise_signal(signal.SIGINT)
            reached.append("after the signal")
            interrupts.poll(0.0)
            reached.append("after the poll")
    assert reached == ["after the signal"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert signal.getsignal(signal.SIGTERM) is handlers


def test_each_signal_is_raised_by_its_own_handler_and_the_first_one_wins(handlers):
    with pytest.raises(Polite):
        with interrupts.at_polls():
            signal.raise_signal(signal.SIGTERM)
            signal.raise_signal(signal.SIGINT)
            interrupts.check()


def test_a_signal_at_the_end_of_a_clean_block_is_raised_as_it_leaves(handlers):
    with pytest.raises(KeyboardInterrupt):
        with interrupts.at_polls():
            signal.raise_signal(signal.SIGINT)


def test_a_signal_while_the_block_fails_is_dropped_for_its_error(handlers):
    with pytest.raises(ValueError):
        with interrupts.at_polls():
            signal.raise_signal(signal.SIGINT)
            raise ValueError("the motion failed first")
    interrupts.check()   # nothing left over for a later block


def test_a_nested_block_and_a_decorated_function_share_the_outer_block(handlers):
    @interrupts.taken_at_polls
    def inner():
        signal.raise_signal(signal.SIGINT)
        return "returned"

    with pytest.raises(KeyboardInterrupt):
        with interrupts.at_polls():
            assert inner() == "returned"   # the inner block leaves without raising: the outer one holds it
            interrupts.check()


def test_an_ignored_signal_stays_ignored(handlers):
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    with interrupts.at_polls():
        signal.raise_signal(signal.SIGINT)
        interrupts.check()
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN


STRESS = textwrap.dedent("""
    import queue, random, signal, threading, time
    from ur3dq.robot import interrupts

    messages, armed, main = queue.Queue(), threading.Event(), threading.main_thread().ident
    signal.signal(signal.SIGINT, signal.default_int_handler)   # a test runner in the background inherits it ignored

    def feed():
        while True:
            messages.put(1)
            time.sleep(0.0002)

    def spray():   # one SIGINT at a random instant of each run
        while True:
            armed.wait()
            armed.clear()
            time.sleep(random.uniform(0.0, 0.003))
            signal.pthread_kill(main, signal.SIGINT)

    def drain():
        while True:
            try:
                messages.get_nowait()
            except queue.Empty:
                return

    threading.Thread(target=feed, daemon=True).start()
    threading.Thread(target=spray, daemon=True).start()
    for run in range({runs}):
        try:
            with {block}:
                armed.set()
                while True:
                    drain()
                    interrupts.check()
        except KeyboardInterrupt:
            drain()   # the clean-up: waits forever if the interrupt left the queue's lock taken
    print("done")
""")


def test_sigint_sprayed_at_a_loop_that_drains_a_queue_never_leaves_its_lock_taken():
    loop = STRESS.format(runs=100, block="interrupts.at_polls()")
    # A hang is forever; a loaded machine (the spinning loop holds the GIL, the other threads wait their turn) may
    # take many times what takes a second alone.
    result = subprocess.run([sys.executable, "-c", loop], capture_output=True, text=True, timeout=120)
    assert result.stdout.strip() == "done", result.stderr
