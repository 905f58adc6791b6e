"""Timed socket reads of a URScript program, as URCL's External Control script uses them: its main loop reads the
reverse socket with a timeout (URCL's default 200 ms; its examples write a keep-alive every 100 ms) and halts when a
read returns [0]. A read times out only when no data arrived in time, however late the interpreter's own thread
runs; a halt that follows is logged with the read that timed out."""
import logging
import socket
import struct
import subprocess
import sys
import textwrap
import time

from polling import wait_for
from sim_ursim.launch import running_simulator

STALL = 1.0  # s the test holds the GIL: past the 0.2 s read timeout, with slack for a late sender process

# Counts the integers it reads until -1; a read that times out writes -1 to register 0 and halts (as External
# Control does on its reverse socket).
READER_PROGRAM = """def reader():
  socket_open("{host}", {port}, "s")
  n = 0
  while True:
    r = socket_read_binary_integer(1, "s", 0.2)
    if r[0] == 0:
      write_output_integer_register(0, -1)
      halt
    end
    if r[1] < 0:
      break
    end
    n = n + 1
    write_output_integer_register(0, n)
  end
  write_output_integer_register(1, 1)
end
"""

# Says it is ready, then writes the second integer 0.1 s after a go byte on stdin, then -1: a client in a process
# of its own, which the GIL of the simulator's process does not hold up.
SENDER = textwrap.dedent("""
    import socket, struct, sys, time
    connection = socket.socket(fileno=int(sys.argv[1]))
    sys.stdout.buffer.write(b"r")
    sys.stdout.flush()
    sys.stdin.buffer.read(1)
    time.sleep(0.1)
    connection.sendall(struct.pack(">i", 2))
    time.sleep(0.05)
    connection.sendall(struct.pack(">i", -1))
""")


def hold_the_gil(seconds):
    """Hold the GIL for about `seconds` in one C call (sum over a range never lets other threads in): how the
    control loop's and publishers' threads can keep a script thread from running."""
    began = time.perf_counter()
    sum(range(1_000_000))
    per_million = time.perf_counter() - began
    sum(range(int(seconds / per_million * 1_000_000)))


def accepted_program(controller, host):
    """Run READER_PROGRAM against a listener on `host`; the program's connection once it has opened it."""
    with socket.create_server((host, 0)) as server:
        server.settimeout(10)
        assert controller.run_program(READER_PROGRAM.format(host=host, port=server.getsockname()[1]), "test")
        connection, _ = server.accept()
    return connection


def test_data_that_arrived_in_time_is_read_even_when_the_reading_thread_runs_late():
    """The reader waits 0.2 s; the client's next integer arrives after 0.1 s, while the simulator's process cannot
    run Python for 1 s. Before, the read gave up on waking past its deadline without looking at the bytes
    waiting in the socket ([0]: External Control halted, URCL logged 'Connection to reverse interface dropped')."""
    with running_simulator(model="ur5e") as sim:
        controller = sim.controller
        connection = accepted_program(controller, sim.host)
        with connection, subprocess.Popen([sys.executable, "-c", SENDER, str(connection.fileno())],
                                          stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                          pass_fds=[connection.fileno()]) as sender:
            assert sender.stdout.read(1) == b"r"  # started: it will write on time after the go byte
            connection.sendall(struct.pack(">i", 1))
            assert wait_for(lambda: controller.state().output_int_registers[0] == 1, timeout=5)
            sender.stdin.write(b"g")
            sender.stdin.flush()  # the program's next read has begun: the sender writes 0.1 s into it
            hold_the_gil(STALL)
            assert sender.wait(10) == 0
        assert wait_for(lambda: not controller.state().program_running, timeout=5)
        registers = controller.state().output_int_registers
        assert registers[0] == 2 and registers[1] == 1, f"registers 0, 1: {registers[0]}, {registers[1]}"


def test_a_halt_after_a_timed_out_read_is_logged_with_the_read(caplog):
    """The simulator's log says why External Control ended: its halt, and the read that timed out before it."""
    with running_simulator(model="ur5e") as sim:
        with caplog.at_level(logging.INFO, logger="sim_ursim.urscript"):
            with accepted_program(sim.controller, sim.host):  # nothing is sent: the first read times out
                assert wait_for(lambda: "program reader ended" in caplog.text, timeout=5)
        assert sim.controller.state().output_int_registers[0] == -1
        assert ('program reader ended: halt in thread reader at line 8, after socket_read_binary_integer("s") got no '
                'data within 0.200 s') in caplog.text
