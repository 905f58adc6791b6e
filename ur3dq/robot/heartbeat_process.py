"""The heartbeat's own process: writes RTDE `input_int_register_20` every PERIOD while the ur3dq process that started
it is alive, running and ticking.

ur3dq.robot.heartbeat.Heartbeat starts it with the interpreter that runs ur3dq (`python -I -S -c ...`, `main`); it
imports nothing but the RTDE inputs (no numpy, no client library) and holds an RTDE connection of its own with this
one register. Its beats do not wait for ur3dq's GIL: a C call or a parser holding it, or ur3dq's threads starved
on a loaded machine, no longer stop a healthy program. It stops beating — and the controller's watchdog then stops
the program armed on the register 1/WATCHDOG_FREQUENCY s after the last beat — when its parent:

- dies (kill -9, a crash, any exit): it is exiting from that instant (PF_EXITING in /proc/<pid>/stat, read every
  beat: the kernel closes its pipes only once it has freed its memory, which takes a big process tenths of a
  second on a loaded machine); then the pipe from it ends, and this process exits. Its parent's pid changing is
  checked every beat as well (a parent gone before this process could read its pipe). Linux's
  PR_SET_PDEATHSIG is not used: it fires when the *thread* that started the child ends, and the driver starts the
  heartbeat from whichever thread sends the first program (a screen worker thread that then ends);
- is stopped (SIGSTOP, SIGTSTP, a debugger): its state in /proc/<pid>/stat, read every beat;
- sends no tick for HANG_TOLERANCE s: its interpreter is frozen while alive and running (a C call that never
  returns the GIL). The parent ticks from a thread every TICK_PERIOD, so only a freeze longer than the tolerance
  stops the arm, not the GIL stalls a loaded machine or a client library cause (docs/performance.md).

It beats again once its parent runs and ticks again (as a thread in ur3dq would after a stall): a program stopped
by the watchdog stays stopped, and the watchdog is removed with it.

The pipe carries one ASCII line per message. From the parent (stdin): `t` (a tick), `w <time>` (measure gaps from
`<time>`, time.monotonic() of the parent: the clock is the system's), `g` (ask for the longest gap). To the parent
(stdout): `ready` (the first value is written), `refused <reason>` (the connection failed; the process exits),
`gap <s>` (the answer to `g`), `failed <longest gap> <last write> <reason>` (a write failed; the process exits).
"""
from __future__ import annotations

import os
import select
import signal
import sys
import time

from ur3dq.errors import RobotConnectionError
from ur3dq.robot.rtde_inputs import RTDEInputs

#: The RTDE input integer register the heartbeat counts on (in ur_rtde's lower range, 18–22: a user's
#: RTDEIOInterface on the same arm is refused while ur3dq holds it, and the other way round).
HEARTBEAT_REGISTER = 20
#: Seconds between heartbeats: ten per watchdog period (0.1 s), so a loaded machine that delays a few is not a stop.
PERIOD = 0.01
#: Seconds between the parent's ticks.
TICK_PERIOD = 0.05
#: Seconds without a tick after which the parent counts as frozen and the beats stop: above the longest stall of
#: ur3dq's threads seen on a loaded machine (docs/performance.md), and ur3dq's own limit for a silent RTDE state
#: stream (a stream silent this long is frozen).
HANG_TOLERANCE = 1.0
#: SCHED_FIFO priority of the beats where the user may raise it (raise_priority): the lowest, above every ordinary
#: process.
REALTIME_PRIORITY = 1
#: /proc/<pid>/stat's flags bit set from the instant a process starts to exit (Linux's PF_EXITING).
PF_EXITING = 0x4


def parent_halted(stat_fd: int) -> bool:
    """Whether the process whose /proc/<pid>/stat is open as `stat_fd` is stopped (state T or t) or exiting (PF_EXITING
    set, state Z or X); False when it cannot be read (the process is gone: the pipe tells that)."""
    try:
        stat = os.pread(stat_fd, 1024, 0)
    except OSError:
        return False
    fields = stat[stat.rfind(b")") + 2:].split()   # after the command name, which may hold any character
    return len(fields) > 6 and (fields[0] in (b"T", b"t", b"Z", b"X") or bool(int(fields[6]) & PF_EXITING))


class Beats:
    """The beat loop of this process, on `inputs` (holding HEARTBEAT_REGISTER), for the parent `parent` (a pid)."""

    def __init__(self, inputs: RTDEInputs, parent: int) -> None:
        self.inputs = inputs
        self.parent = parent
        self.count = 0
        now = time.monotonic()
        self.last_write = self.last_tick = self.watched_from = now
        self.longest = 0.0
        try:
            self.stat_fd: int | None = os.open(f"/proc/{parent}/stat", os.O_RDONLY)
        except OSError:   # no /proc: a stopped parent is caught by its missing ticks
            self.stat_fd = None

    def gap(self, now: float) -> float:
        """The longest time (s) without a write since the watch began, the time since the last write included."""
        return max(self.longest, now - max(self.last_write, self.watched_from))

    def beat(self) -> bool:
        """Write the next value; False (and `failed` told) when the write failed."""
        self.count = (self.count + 1) % 2 ** 31
        if not self.inputs.set_int_register(HEARTBEAT_REGISTER, self.count):
            now = time.monotonic()
            tell(f"failed {self.gap(now):.6f} {self.last_write!r} the RTDE connection to {self.inputs.host} dropped")
            return False
        now = time.monotonic()
        self.longest = max(self.longest, now - max(self.last_write, self.watched_from))
        self.last_write = now
        return True

    def parent_running(self, now: float) -> bool:
        """Whether the parent ticked within HANG_TOLERANCE and is neither stopped nor exiting."""
        if now - self.last_tick > HANG_TOLERANCE:
            return False
        return self.stat_fd is None or not parent_halted(self.stat_fd)

    def obey(self, line: bytes) -> None:
        """Carry out one message of the parent."""
        now = time.monotonic()
        self.last_tick = now   # any message is a sign of life
        if line.startswith(b"w "):
            self.watched_from, self.longest = float(line[2:]), 0.0
        elif line == b"g":
            tell(f"gap {self.gap(now):.6f}")

    def run(self) -> None:
        """Beat every PERIOD until the parent is gone (its pipe ends, or it is no longer the parent) or a write
        fails; between beats, read the parent's messages."""
        if not self.beat():
            return
        tell("ready")
        pending, next_beat = b"", time.monotonic() + PERIOD
        while True:
            # The pipe is read even when the beats run late: its end must never wait behind them.
            if select.select([0], [], [], max(0.0, next_beat - time.monotonic()))[0]:
                data = os.read(0, 4096)
                if not data:
                    return   # the parent closed the pipe or died
                *lines, pending = (pending + data).split(b"\n")
                for line in lines:
                    self.obey(line)
                continue
            if os.getppid() != self.parent:
                return
            now = time.monotonic()
            next_beat = max(next_beat + PERIOD, now + PERIOD / 2)
            if self.parent_running(now) and not self.beat():
                return


def raise_priority() -> bool:
    """Run at the lowest real-time priority (SCHED_FIFO 1) where this user may; True when it does.

    On a loaded machine an ordinary process can wait a quarter of a second for a CPU, longer than the watchdog
    allows between beats, and the controller then stops a healthy program. A real-time process runs as soon as it
    wakes. It needs CAP_SYS_NICE or an RLIMIT_RTPRIO of at least 1 (docs/architecture.md says how to grant it); without
    it the beats run as an ordinary process. The beats sleep between writes, so they cannot hold a CPU.
    """
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(REALTIME_PRIORITY))
    except (AttributeError, OSError):   # not Linux, or not allowed
        return False
    return True


def tell(text: str) -> None:
    """One line to the parent (BrokenPipeError when it is gone)."""
    os.write(1, text.encode("ascii", "replace") + b"\n")


def main(argv: list[str]) -> int:
    """`argv`: the controller's host, the parent's pid. Returns the exit status: 1 when the connection was refused,
    else 0 (a failed write is told to the parent)."""
    # Ctrl-C, a hang-up or SIGTERM sent to ur3dq's process group are ur3dq's to handle (it stops the arm itself):
    # this process beats on until ur3dq ends, which it reads from its pipe.
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, signal.SIG_IGN)
    host, parent = argv[0], int(argv[1])
    if os.getppid() != parent:
        return 0
    raise_priority()
    try:
        inputs = RTDEInputs(host, (HEARTBEAT_REGISTER,), outputs=False)
    except RobotConnectionError as error:
        tell(f"refused {error}")
        return 1
    beats = Beats(inputs, parent)
    try:
        beats.run()
    except BrokenPipeError:   # the parent is gone
        return 0
    finally:
        inputs.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
