"""Ending the threads of a test's fake server: a socket shut down wakes the thread blocked on it."""
import contextlib
import socket


def shut(sock):
    """Shut `sock` down, then close it. On Linux, close() alone leaves a thread blocked in its accept() or recv()
    blocked for the rest of the process; shutdown() wakes it (accept raises, recv returns b"")."""
    with contextlib.suppress(OSError):
        sock.shutdown(socket.SHUT_RDWR)
    sock.close()


def join_all(threads, timeout=5.0):
    """Join every thread of `threads`; AssertionError naming one still running after `timeout` s."""
    for thread in threads:
        thread.join(timeout)
        assert not thread.is_alive(), f"thread {thread.name} of a fake server did not end"
