"""Chaos: 30 faults at random instants of a 7-step cell program that `run-poses` runs on a simulator.

The program is a joint approach, a linear descent, the gripper (tool output 0) on, a wait, a linear retract, a joint
move to the place and the gripper off. The faults, drawn with a fixed seed: a protective stop, an emergency stop,
every connection dropped, the streams frozen, latency on every send, SIGKILL or SIGSTOP of ur3dq, SIGKILL of the
simulator. Every run must end with a documented exit code (0 only for a program that ran to its end, with the arm
on its last target) and exactly one error line, the notes on lines of their own before it; the arm must be at rest
within the heartbeat bound of the fault (or of ur3dq's end, when the fault leaves ur3dq in charge); the store must
be byte-identical; and the error must name the tool output when the program left it on.

Runs go LANES at a time, each lane with a simulator process of its own, watched through the simulator's control
channel (which no fault touches): its joints and outputs about every 10 ms.
"""
import contextlib
import dataclasses
import json
import random
import re
import signal
import socket
import subprocess
import threading
import time

import numpy as np
import pytest

from cli_support import UR3DQ, cli_env
from robot_target import simulator_only
from sim_ursim.control_channel import CONTROL_PORT, encode_request, send_request
from sim_ursim.launch import simulator_process
from sim_ursim.vocabulary import PROTECTIVE_STOP_DECELERATION
from ur3dq import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.program.steps import DigitalOut, Motion, RelativeWaypoint, Wait, Waypoint
from ur3dq.robot.heartbeat import PERIOD, WATCHDOG_FREQUENCY
from ur3dq.robot.robot import SAFE_STOP_DECELERATION
from ur3dq.store import PoseStore

# Timing-sensitive (the arm at rest within the heartbeat bound) and CPU-heavy (three simulators): run alone.
pytestmark = [simulator_only("injecting faults into the simulator and killing it"), pytest.mark.exclusive]

SEED = 34
FAULTS = 30
LANES = 3
KINDS = ("protective-stop", "emergency-stop", "drop-connections", "freeze", "latency", "kill-ur3dq", "stop-ur3dq",
         "kill-simulator")
RUN_SECONDS = 2.0   # faults land this long at most after the arm starts moving (the program takes ~2.5 s)
HUNG = 0.5   # s a SIGSTOPped ur3dq stays stopped before SIGCONT

MODEL = robot_model("ur3")
START = np.array([0.1, -1.4, 1.5, -1.7, -1.5708, 0.0])
Q_APPROACH = np.array([0.3, -1.3, 1.4, -1.7, -1.5708, 0.2])
Q_PLACE = np.array([0.8, -1.2, 1.3, -1.7, -1.5708, 0.6])
FAST = Motion("joint", 2.0, 4.0)   # rad/s, rad/s²: a short program
TOOL_OUTPUT_0 = 1 << 16   # digital_output_bits: the tool outputs are bits 16-17
# The watchdog stops a program 1/WATCHDOG_FREQUENCY after the last heartbeat (at most a PERIOD before the fault);
# then the arm decelerates from at most FAST's speed; SLACK is the observer's sampling on a loaded machine.
DETECTION = 1.0 / WATCHDOG_FREQUENCY + PERIOD + 0.005
SLACK = 0.25
# The controller stops the arm by itself (its watchdog, a safety stop) at its stop deceleration; after a lost
# connection too, since ur3dq then ends its heartbeat rather than send a gentler stopj.
HEARTBEAT_BOUND = DETECTION + FAST.speed / PROTECTIVE_STOP_DECELERATION + SLACK
# ur3dq stops the arm itself after a fault it sees on live connections with stopj at SAFE_STOP_DECELERATION.
STOPJ_BOUND = DETECTION + FAST.speed / SAFE_STOP_DECELERATION + SLACK
# The arm is at rest this long after the fault at the latest (the others leave ur3dq in charge: it must have it at
# rest within STOPJ_BOUND of its own end).
REST_AFTER_FAULT = {kind: HEARTBEAT_BOUND for kind in ("kill-ur3dq", "stop-ur3dq", "emergency-stop", "protective-stop",
                                                       "drop-connections")}
STOPPED_DURING = re.compile(r"^Stopped during step (\d+) of 7\b", re.MULTILINE)


@dataclasses.dataclass(frozen=True)
class Fault:
    kind: str
    instant: float   # s after the arm starts moving
    seconds: float   # how long a freeze lasts, the latency added (ur3dq calls a stream frozen after 1 s)


def drawn_faults():
    """FAULTS faults, every kind about as often, in an order and at instants drawn from SEED."""
    draw = random.Random(SEED)
    kinds = [KINDS[index % len(KINDS)] for index in range(FAULTS)]
    draw.shuffle(kinds)
    return [Fault(kind, draw.uniform(0.0, RUN_SECONDS), draw.uniform(0.1, 2.5)) for kind in kinds]


def write_program(path):
    """The 7-step program, stored as `record-pose` and `poses` would store it."""
    approach = MODEL.fk(Q_APPROACH)
    pick = approach * DualQuaternion.from_translation([0.0, 0.0, 0.05])   # 5 cm along the tool's z: a descent

    def waypoint(name, pose, joints, motion=FAST):
        return Waypoint(name, Pose.from_dual_quaternion(name, pose, "ur3", joints=tuple(joints)), motion)

    steps = [waypoint("approach", approach, Q_APPROACH),
             waypoint("pick", pick, MODEL.ik(pick, Q_APPROACH), Motion("linear", 0.25)),
             DigitalOut("grip", "tool", 0, True), Wait("settle", 0.2),
             RelativeWaypoint("retract", "pick", (0, 0, -0.05, 0, 0, 0), motion=Motion("linear", 0.25)),
             waypoint("place", MODEL.fk(Q_PLACE), Q_PLACE), DigitalOut("release", "tool", 0, False)]
    PoseStore(path).update_program(lambda old: (steps, None))


class Observer:
    """The simulator's joints and digital outputs about every 10 ms from a thread, through its control channel."""

    def __init__(self, host):
        self.samples = []   # (monotonic time, joints (6,), digital output bits)
        self._connection = socket.create_connection((host, CONTROL_PORT), timeout=5)
        self._reader = self._connection.makefile("rb")
        self._closing = threading.Event()
        self._thread = threading.Thread(target=self._follow, daemon=True)
        self._thread.start()

    def _follow(self):
        try:
            while not self._closing.is_set():
                self._connection.sendall(encode_request("status"))
                line = self._reader.readline()
                if not line:
                    return
                state = json.loads(line)["state"]
                self.samples.append((time.monotonic(), np.array(state["q"]), state["digital_output_bits"]))
                time.sleep(0.01)
        except OSError:   # the simulator was killed
            return

    def moved_from(self, q):
        return bool(self.samples) and np.max(np.abs(self.samples[-1][1] - q)) > 1e-3

    def close(self):
        self._closing.set()
        self._thread.join(5)
        self._connection.close()

    def rest_time(self):
        """When the arm came to rest where it was last seen: the first sample of the last still run."""
        last = self.samples[-1][1]
        moving = [index for index, (_, q, _) in enumerate(self.samples) if np.max(np.abs(q - last)) > 1e-6]
        return self.samples[moving[-1] + 1][0] if moving else self.samples[0][0]


def dashboard(host, *commands):
    """The dashboard server's reply to each command, as any dashboard client sends them."""
    with socket.create_connection((host, 29999), timeout=5) as connection:
        reader = connection.makefile("rb")
        reader.readline()   # the greeting
        replies = []
        for command in commands:
            connection.sendall(f"{command}\n".encode())
            replies.append(reader.readline().decode().strip())
    return replies


def wait_until(condition, timeout, what):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


@dataclasses.dataclass
class Outcome:
    fault: Fault
    returncode: int
    stdout: str
    stderr: str
    fault_at: float
    ended_at: float   # ur3dq's end: its exit, or the signal that killed or hung it
    rest_at: float | None   # None: the simulator is gone
    outputs: int | None   # the controller's digital output bits after the run (None: gone)
    store_kept: bool


class Lane:
    """A simulator process of its own (a new one after one is killed) and a directory with the program's store."""

    def __init__(self, directory):
        directory.mkdir()
        self.directory, self.store = directory, directory / "poses.json"
        write_program(self.store)
        self.simulator, self._stack = None, contextlib.ExitStack()

    def close(self):
        self._stack.close()

    def ready(self):
        """The simulator running and powered, nothing running, the gripper off, the arm at START."""
        if self.simulator is None or self.simulator.process.poll() is not None:
            self._stack.close()
            self._stack = contextlib.ExitStack()
            self.simulator = self._stack.enter_context(simulator_process(model="ur3", initial_q=list(START)))
        host = self.simulator.host
        send_request(host, "reset")
        state = send_request(host, "status")["state"]
        if state["safety_mode"] == "ROBOT_EMERGENCY_STOP":
            send_request(host, "release-emergency-stop")
        if state["safety_mode"] == "PROTECTIVE_STOP":   # a controller keeps it 5 s
            wait_until(lambda: dashboard(host, "unlock protective stop")[0].startswith("Protective stop releasing"),
                       10, "the protective stop never unlocked")
        if state["program_running"]:
            dashboard(host, "stop")
        self._power_up(host)
        if send_request(host, "status")["state"]["digital_output_bits"] & TOOL_OUTPUT_0:
            send_to_secondary(host, "sec off():\n  set_tool_digital_out(0, False)\nend\n")
            wait_until(lambda: not send_request(host, "status")["state"]["digital_output_bits"] & TOOL_OUTPUT_0,
                       5, "the gripper output never went off")
        for command, arguments in (("freedrive", {"on": True}), ("move-by-hand", {"q": list(START)}),
                                   ("freedrive", {"on": False})):
            assert send_request(host, command, **arguments).get("ok")

    @staticmethod
    def _power_up(host):
        """Power on and release the brakes, as an operator does: each command once, then wait for its mode."""
        def mode():
            return send_request(host, "status")["state"]["robot_mode"]

        if mode() == "POWER_OFF":
            dashboard(host, "power on")
            wait_until(lambda: mode() == "IDLE", 15, "the simulator never got IDLE")
        if mode() == "IDLE":
            dashboard(host, "brake release")
        wait_until(lambda: mode() == "RUNNING", 15, "the simulator never got RUNNING")
        wait_until(lambda: not send_request(host, "status")["state"]["program_running"], 5, "a program still runs")

    def run(self, fault):
        """One run of the program with `fault` injected `fault.instant` s after the arm starts moving."""
        self.ready()
        simulator, before = self.simulator, self.store.read_bytes()
        observer = Observer(simulator.host)
        with subprocess.Popen([UR3DQ, "--host", simulator.host, "run-poses", "--yes"], cwd=self.directory,
                              env=cli_env(self.directory), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) as process:
            try:
                wait_until(lambda: observer.moved_from(START) or process.poll() is not None, 60,
                           "the arm never moved")
                time.sleep(fault.instant)
                fault_at = time.monotonic()
                inject(fault, simulator, process)
                stdout, stderr = process.communicate(timeout=60)
                ended_at = fault_at if fault.kind in ("kill-ur3dq", "stop-ur3dq") else time.monotonic()
            finally:
                if process.poll() is None:
                    process.kill()
        alive = simulator.process.poll() is None
        time.sleep(max(0.0, ended_at + STOPJ_BOUND + 0.3 - time.monotonic()))   # the arm stays at rest
        observer.close()
        rest_at = observer.rest_time() if alive else None
        outputs = send_request(simulator.host, "status")["state"]["digital_output_bits"] if alive else None
        return Outcome(fault, process.returncode, stdout, stderr, fault_at, ended_at, rest_at, outputs,
                       self.store.read_bytes() == before)


def send_to_secondary(host, script):
    """`script` sent to the secondary interface (30002), as another client would; returns once it is read."""
    with socket.create_connection((host, 30002), timeout=5) as connection:
        connection.sendall(script.encode())
        connection.shutdown(socket.SHUT_WR)
        with contextlib.suppress(OSError):
            while connection.recv(65536):
                pass


def inject(fault, simulator, process):
    """Inject `fault` into the run of `process` on `simulator`."""
    if fault.kind == "kill-ur3dq":
        process.send_signal(signal.SIGKILL)
    elif fault.kind == "stop-ur3dq":
        process.send_signal(signal.SIGSTOP)
        time.sleep(HUNG)
        process.send_signal(signal.SIGCONT)
    elif fault.kind == "kill-simulator":
        simulator.process.send_signal(signal.SIGKILL)
    elif fault.kind in ("freeze", "latency"):
        assert send_request(simulator.host, fault.kind, seconds=fault.seconds).get("ok")
    else:
        assert send_request(simulator.host, fault.kind).get("ok")


def problems_of(outcome):
    """What is wrong with one run's end (empty when it ended as every run must)."""
    fault, problems = outcome.fault, []
    lines = [line for line in outcome.stderr.splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("Error")]
    if not outcome.store_kept:
        problems.append("the store changed")
    if fault.kind == "kill-ur3dq":
        if outcome.returncode not in (-signal.SIGKILL, 0):
            problems.append(f"exit {outcome.returncode} after SIGKILL")
    elif outcome.returncode == 0:
        if "Ran 7 steps" not in outcome.stdout or errors:
            problems.append("exit 0 without the whole program run")
    elif outcome.returncode != 6:
        problems.append(f"exit {outcome.returncode}, not a documented fault exit (6)")
    elif len(errors) != 1 or lines[-1] != errors[0] or not errors[0].startswith("Error: "):
        problems.append("not exactly one error line, last")
    if any(text in outcome.stderr for text in ("Traceback", "terminate called")):
        problems.append("a traceback or an abort")
    if outcome.rest_at is not None:
        if outcome.rest_at > outcome.ended_at + STOPJ_BOUND:
            problems.append(f"the arm moved {outcome.rest_at - outcome.ended_at:.3f} s after ur3dq's end")
        if outcome.rest_at > outcome.fault_at + REST_AFTER_FAULT.get(fault.kind, np.inf):
            problems.append(f"the arm came to rest {outcome.rest_at - outcome.fault_at:.3f} s after the fault")
    if outcome.returncode == 6 and errors:
        problems += output_problems(outcome, errors[0])
    return problems


def output_problems(outcome, error):
    """The error names tool output 0 when the program left it on (read from the controller, or when the simulator is
    gone, from the step the run stopped during: after the grip, before the release)."""
    if outcome.outputs is not None:
        left_on = bool(outcome.outputs & TOOL_OUTPUT_0)
    else:
        stopped = STOPPED_DURING.search(outcome.stderr)
        left_on = stopped is not None and 4 <= int(stopped.group(1)) <= 6
    if left_on and "tool output 0" not in error:
        return ["the gripper output is on and the error does not say so"]
    if outcome.outputs is not None and not left_on and "tool output 0 still on" in error:
        return ["the error says the gripper output is on; it is off"]
    return []


def test_thirty_faults_at_random_instants_each_end_documented_at_rest_and_the_store_kept(tmp_path):
    faults = drawn_faults()
    assert set(KINDS) <= {fault.kind for fault in faults}
    lanes = [Lane(tmp_path / f"lane{index}") for index in range(LANES)]
    outcomes, failures = [], []

    def work(lane, share):
        try:
            outcomes.extend(lane.run(fault) for fault in share)
        except BaseException as error:   # reported below, with the runs that did end
            failures.append(f"{lane.directory.name}: {type(error).__name__}: {error}")

    threads = [threading.Thread(target=work, args=(lane, faults[index::LANES])) for index, lane in enumerate(lanes)]
    try:
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        for lane in lanes:
            lane.close()
    report = [f"{outcome.fault} -> exit {outcome.returncode}: {'; '.join(problems)}\n{outcome.stderr}"
              for outcome in outcomes for problems in [problems_of(outcome)] if problems]
    assert not failures and not report, "\n".join(failures + report)
    assert len(outcomes) == FAULTS
    assert {outcome.returncode for outcome in outcomes} >= {6, -signal.SIGKILL}
