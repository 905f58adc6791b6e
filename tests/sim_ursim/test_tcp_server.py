"""What every port of the simulator shares (sim_ursim/tcp_server.py): a bounded number of clients per port."""
import logging
import socket
import struct
import threading
import time

import pytest

from polling import wait_for
from sim_ursim.controller import Controller
from sim_ursim.launch import running_simulator
from sim_ursim.primary.server import RealtimeServer
from sim_ursim.rtde import protocol as rtde_protocol
from sim_ursim.rtde.server import RTDEServer
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


@pytest.mark.parametrize("server_class", [RTDEServer, RealtimeServer])
def test_a_streamer_without_clients_waits_for_one_and_then_streams_every_cycle(server_class):
    """With nobody connected a per-cycle streamer (RTDE, realtime) sleeps instead of taking every cycle (at 500 Hz
    that was 500 wake-ups a second, each one a turn of the GIL); a client that connects then gets a frame every
    cycle, in order."""
    controller = Controller(model="ur3e")
    calls = []
    take_cycles = controller.cycles_after
    controller.cycles_after = lambda *args, **kwargs: calls.append(1) or take_cycles(*args, **kwargs)
    controller.start()
    server = server_class(controller, "127.0.0.1", 0).start()
    try:
        time.sleep(0.4)  # 200 cycles
        assert len(calls) <= 10
        stamps = _timestamps(server_class, server.port, 100)
    finally:
        server.stop()
        controller.shutdown()
    steps = [round((b - a) / controller.period, 6) for a, b in zip(stamps[:-1], stamps[1:], strict=True)]
    assert steps == [1.0] * len(steps)


def _timestamps(server_class, port, count):
    """`count` consecutive timestamps streamed to a new client of `server_class` (RTDE: a raw protocol-2 reader)."""
    with socket.create_connection(("127.0.0.1", port), timeout=5) as sock:
        if server_class is RTDEServer:
            for request in (rtde_protocol.pack_protocol_version_request(2),
                            rtde_protocol.pack_setup_outputs_request(["timestamp"], 500, 2),
                            rtde_protocol.pack_start_request()):
                sock.sendall(request)
        buffer, stamps = bytearray(), []
        while len(stamps) < count:
            buffer += sock.recv(65536)
            if server_class is RTDEServer:
                while (package := rtde_protocol.split_package(buffer)) is not None:
                    del buffer[:package[2]]
                    if package[0] == rtde_protocol.PackageType.DATA_PACKAGE:
                        stamps.append(struct.unpack_from(">d", package[1], 1)[0])
            else:  # realtime: length-prefixed packages whose first double is the time
                while len(buffer) >= 4 and len(buffer) >= (size := struct.unpack_from(">i", buffer)[0]):
                    stamps.append(struct.unpack_from(">d", buffer, 4)[0])
                    del buffer[:size]
    return stamps[:count]
