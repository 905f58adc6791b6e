"""What every port of the simulator shares (sim_ursim/tcp_server.py): a bounded number of clients per port."""
import logging
import socket
import threading
import time

from polling import wait_for
from sim_ursim.launch import running_simulator
from sim_ursim.tcp_server import MAX_CONNECTIONS

GREETING = b"Connected: Universal Robots Dashboard Server\n"


def _greeted(sock: socket.socket) -> bool:
    """True when the dashboard greets this connection; False when it was reset or closed without a word."""
    try:
        return sock.recv(len(GREETING)) == GREETING
    except (TimeoutError, ConnectionResetError):
        return False


def test_a_port_serves_a_bounded_number_of_clients_and_resets_the_rest_at_once(caplog):
    """A flood of connections gets MAX_CONNECTIONS served clients (a thread each) and the rest reset at once,
    logged in one line, not one thread and one line each; a served client leaving frees its place."""
    with running_simulator(model="ur3") as sim, caplog.at_level(logging.WARNING, logger="sim_ursim.server"):
        threads_before = threading.active_count()
        began = time.monotonic()
        flood = [socket.create_connection((sim.host, 29999), timeout=5) for _ in range(MAX_CONNECTIONS + 40)]
        try:
            greeted = [_greeted(sock) for sock in flood]
            elapsed = time.monotonic() - began
            assert greeted == [True] * MAX_CONNECTIONS + [False] * 40
            assert elapsed < 3.0  # the refused ones were reset at once, not left to time out
            assert threading.active_count() - threads_before <= MAX_CONNECTIONS
            assert wait_for(lambda: any("refused" in r.getMessage() for r in caplog.records))
            refusals = [r.getMessage() for r in caplog.records if "refused" in r.getMessage()]
            assert len(refusals) <= 3 and sum(int(line.split("refused ")[1].split()[0]) for line in refusals) <= 40
            flood[0].close()
            assert wait_for(lambda: len(sim.servers["dashboard"].connections()) < MAX_CONNECTIONS)
            with socket.create_connection((sim.host, 29999), timeout=5) as late:
                assert _greeted(late)
        finally:
            for sock in flood:
                sock.close()
