"""The cell behind the page: one Robot connection (made, and made again, in the background), the live state read
STATE_RATE times a second, and the program in the store, watched for changes from any writer.

Every reading goes to `on_state(snapshot)` and every program change to `on_program(steps)`: the server turns them
into messages for its pages. The station moves nothing by itself; ur3dq.screen.operations does, on its request.
"""
from __future__ import annotations

import dataclasses
import os
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ur3dq.errors import RobotError, StoreError, UR3DQError
from ur3dq.kinematics.models import URModel
from ur3dq.pathcheck import Cell
from ur3dq.program.steps import Step, Waypoint
from ur3dq.robot.io_state import DIGITAL_GROUPS, IOState
from ur3dq.robot.jog import KEEPALIVE_REGISTER
from ur3dq.robot.state import robot_mode_name, safety_mode_name
from ur3dq.screen.scene import ArmShape
from ur3dq.screen.views import Snapshot
from ur3dq.store import PoseStore

if TYPE_CHECKING:
    from ur3dq.robot.robot import Robot

STATE_RATE = 30.0          # Hz: the live view's update rate
STORE_POLL = 0.2           # s between two looks at the store file (a change from the CLI shows within this)
RECONNECT_DELAY = 2.0      # s between connection attempts
FREEDRIVE_POLL = 0.5       # s between two looks at whether the controller is in freedrive


@dataclasses.dataclass(frozen=True)
class StationConfig:
    """Where the cell is: the robot's address (None: none configured), client backend, model to expect, store,
    cell (a pathcheck Cell, or None) and its file's name."""

    host: str | None
    backend: str = "rtde"
    model: str | None = None
    store_path: Path = Path("poses.json")
    cell: Cell | None = None
    cell_path: Path | None = None
    no_robot_hint: str = "no robot configured"


class Station:
    """The robot connection, the state poller and the store watcher of one `ur3dq serve`."""

    def __init__(self, config: StationConfig, on_state: Callable[[Snapshot], None],
                 on_program: Callable[[list[Step]], None], prepare: Callable[[Robot], None] | None = None):
        self.config = config
        self.store = PoseStore(config.store_path)
        self.robot: Robot | None = None
        self.shape: ArmShape | None = None
        self.on_state, self.on_program = on_state, on_program
        self._prepare = prepare     # prepare(robot) after connecting, before any motion (ready)
        self.ready = False          # connected and prepared: motions may start
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self.connection_error: str | None = None if config.host else config.no_robot_hint
        self.steps: list[Step] = []
        self.store_error: str | None = None
        self._store_stamp: tuple[int, int, int] | None = None   # the store file's mtime, size, inode
        self.activity: str | None = None        # set by the operations while they move the arm
        self.running_step: str | None = None
        self.freedrive = False                  # the controller is in freedrive (FREEDRIVE_POLL old at most)
        self.loop_text: str | None = None
        self.latest: Snapshot = Snapshot(False, "DISCONNECTED", "", "STOPPED", message=self.connection_error)
        self.robot_lock = threading.RLock()     # serialises the robot calls that are not plain readings

    # ------------------------------------------------------------------------------------------------ lifecycle
    def start(self) -> None:
        """Read the store, then start the connection and polling threads."""
        self.reload_program(force=True)
        for target, name in ((self._connection_loop, "ur3dq-screen-connect"), (self._poll_loop, "ur3dq-screen-poll")):
            thread = threading.Thread(target=target, name=name, daemon=True)
            thread.start()
            self._threads.append(thread)

    def close(self) -> None:
        """Stop the threads and close the robot connection (a running program armed on the heartbeat stops)."""
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=3.0)
        robot, self.robot = self.robot, None
        if robot is not None:
            robot.close()

    def wait_connected(self, timeout: float) -> bool:
        """True once a robot is connected (within `timeout` s)."""
        deadline = time.monotonic() + timeout
        while self.robot is None and time.monotonic() < deadline and not self._stop.is_set():
            time.sleep(0.02)
        return self.robot is not None

    def _connection_loop(self) -> None:
        """Connect (again every RECONNECT_DELAY while there is no robot); while there is one, note every
        FREEDRIVE_POLL whether the controller is in freedrive (a primary-interface reading of its own)."""
        while not self._stop.is_set() and self.config.host:
            robot = self.robot
            if robot is None:
                self._connect_once()
                self._stop.wait(RECONNECT_DELAY)
                continue
            try:
                self.freedrive = robot.freedrive_active()
            except RobotError:
                self.freedrive = False   # the poller notices a lost connection and drops it
            self._stop.wait(FREEDRIVE_POLL)

    def _connect_once(self) -> None:
        try:
            robot = _connect_robot(self.config)
        except (UR3DQError, OSError, RuntimeError) as error:
            self.connection_error = f"cannot connect to {self.config.host}: {error}"
            return
        self.shape = ArmShape(robot.model, self.config.cell.tool if self.config.cell else None)
        self.connection_error = None
        self.robot = robot
        self.on_program(self.steps)   # the frames and the arm's model are known now
        self._make_ready(robot)

    def _make_ready(self, robot: Robot) -> None:
        """Prepare a new connection (its RTDE inputs, whose start holds the interpreter ~0.1 s, and the kernels'
        first compilation) before any motion may start, so that no jog's heartbeat waits behind them."""
        try:
            robot.inputs.set_int_register(KEEPALIVE_REGISTER, 0)   # opens them here, not in the first jog
            if self._prepare is not None:
                self._prepare(robot)
        except (UR3DQError, OSError, RuntimeError) as error:
            self.drop_robot(f"cannot start the RTDE inputs of {self.config.host}: {error}")
            return
        self.ready = robot is self.robot

    def drop_robot(self, reason: str) -> None:
        """Forget a connection that broke (the connection thread makes a new one)."""
        robot, self.robot = self.robot, None
        self.ready = False
        self.connection_error = reason
        if robot is not None:
            try:
                robot.close()
            except (UR3DQError, OSError, RuntimeError):
                pass

    # ------------------------------------------------------------------------------------------------ polling
    def _poll_loop(self) -> None:
        period = 1.0 / STATE_RATE
        next_store_look = 0.0
        while not self._stop.is_set():
            began = time.monotonic()
            self.latest = self.read()
            self.on_state(self.latest)
            if began >= next_store_look:
                next_store_look = began + STORE_POLL
                self.reload_program()
            self._stop.wait(max(period - (time.monotonic() - began), 0.001))

    def read(self) -> Snapshot:
        """One Snapshot of the robot (or of its absence) and of what the server is doing."""
        robot = self.robot
        if robot is None:
            return self._without_robot()
        try:
            status = robot.state()
            io = robot.io_state()
        except RobotError as error:
            self.drop_robot(f"lost the connection to {self.config.host}: {error}")
            return self._without_robot()
        program = "PAUSED" if status.program_paused else "PLAYING" if status.program_running else "STOPPED"
        placed = self.shape.placed(status.joints) if self.shape is not None else None
        return Snapshot(True, robot_mode_name(status.robot_mode), safety_mode_name(status.safety_mode), program,
                        tuple(float(q) for q in status.joints), tuple(float(v) for v in status.tcp_pose), placed,
                        float(status.target_speed_fraction), self.freedrive, _pins(io, True), _pins(io, False),
                        self.activity, self.running_step, self.loop_text, ready=self.ready,
                        read_at=time.time() - status.age, age=float(status.age))

    def _without_robot(self) -> Snapshot:
        return Snapshot(False, "DISCONNECTED", "", "STOPPED", activity=self.activity, running_step=self.running_step,
                        loop=self.loop_text, message=self.connection_error)

    # ------------------------------------------------------------------------------------------------ the store
    def reload_program(self, force: bool = False) -> bool:
        """Read the store again if its file changed (or `force`); True (and on_program) when the program did."""
        try:
            info = os.stat(self.store.path)
            stamp: tuple[int, int, int] | None = (info.st_mtime_ns, info.st_size, info.st_ino)
        except FileNotFoundError:
            stamp = None
        except OSError as error:
            self.store_error = f"{self.store.path}: {error.strerror or error}"
            return False
        if stamp == self._store_stamp and not force:
            return False
        try:
            steps = self.store.load_program()
        except (StoreError, ValueError) as error:
            self.store_error = str(error)
            self._store_stamp = stamp
            self.on_program(self.steps)
            return True
        self._store_stamp, self.store_error, self.steps = stamp, None, steps
        self.on_program(steps)
        return True

    def model(self) -> URModel:
        """The model to plan and check on: the robot's (calibrated, with its TCP), else the nominal one named by
        --model or the program's first recorded pose (ur3 without either)."""
        if self.robot is not None:
            return self.robot.model
        from ur3dq.kinematics import robot_model

        first = next((step.pose.robot_model for step in self.steps if isinstance(step, Waypoint)), None)
        return robot_model(self.config.model or first or "ur3")

    def joints(self) -> np.ndarray | None:
        """The arm's joints now, or None without a robot."""
        robot = self.robot
        return None if robot is None else robot.joints()


def _pins(io: IOState, inputs: bool) -> dict[str, list[bool]]:
    """{group: [on, ...]} of the digital inputs or outputs of an I/O reading."""
    return {group: io.pins(group, inputs) for group, _, _ in DIGITAL_GROUPS}


def _connect_robot(config: StationConfig) -> Robot:
    """A Robot for `config`, refusing every motion whose whole path does not pass the path check in the cell."""
    from ur3dq.robot import connect

    if config.host is None:
        raise RobotError(config.no_robot_hint)
    robot = connect(config.host, backend=config.backend, model=config.model)
    try:
        robot.require_path_check(config.cell)
    except BaseException:
        robot.close()
        raise
    return robot
