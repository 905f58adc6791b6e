"""An exported program played by the simulator's dashboard (`load`, `play`) moves the arm through the joints
`run-poses` plans (and, imported back, runs), at every waypoint within 1e-6 rad: random programs of every move
type, relative waypoints, outputs and waits, on a CB3 (plain XML), an e-series arm (gzip) and a calibrated one;
on each, one program through the command line (export-urp, run-poses --dry-run, play, import-urp, run-poses) and
MORE_PROGRAMS more exported by the library and played: 9 programs played, 3 run by run-poses. The CB3 and the
nominal e-series arm are fast-clock simulators (docs/ursim.md: simulated time only, run-poses included); the
calibrated e-series arm plays and runs in real time, as a controller."""
import gzip
import itertools
import json
import socket
import threading
import time

import numpy as np
import pytest

from polling import wait_for
from sim_ursim.rtde import protocol
from ur3dq.kinematics import robot_model
from ur3dq.polyscope.urp_export import export_bytes
from ur3dq.program.plan import Defaults, motion_ranges, plan_program
from ur3dq.program.steps import Motion, RelativeWaypoint, Wait, WaitInput, Waypoint
from ur3dq.store import PoseStore
from urp_programs import HOME, random_program

TOLERANCE = 1e-6
MORE_PROGRAMS = 2   # played after the one run through the command line, on the same simulator
# an arm off the catalogue by up to 0.4 mm and 0.6 mrad: the export carries its calibration, the pendant plays it
CALIBRATION = {"a": [0.0002, -0.0003, 0.0004, 0.0001, -0.0001, 0.0], "d": [0.0003, 0.0, 0.0, -0.0002, 0.0001, 0.0002],
               "alpha": [0.0005, -0.0003, 0.0002, 0.0006, -0.0004, 0.0], "theta": [0.0, 0.0004, -0.0002, 0.0003, 0.0,
                                                                                 -0.0001]}


def playable(steps, brisk):
    """The program with every waypoint stopping and held for 0.1 s (no blend: the arm rests on it, for the poll to
    see), short waits and input waits the simulator's inputs (all off) satisfy; `brisk`: speeds and accelerations
    raised to at least a third of the model's range (the targets do not depend on them; the time does)."""
    result = []
    for step in steps:
        if result and isinstance(result[-1], (Waypoint, RelativeWaypoint)):
            result.append(Wait(f"hold {len(result)}", 0.1))
        if isinstance(step, Waypoint):
            step = Waypoint(step.name, step.pose, stopping(step.motion, brisk))
        elif isinstance(step, RelativeWaypoint):
            step = RelativeWaypoint(step.name, step.base, step.offset, step.frame, stopping(step.motion, brisk),
                                    step.note)
        elif isinstance(step, Wait):
            step = Wait(step.name, 0.02)
        elif isinstance(step, WaitInput):
            step = WaitInput(step.name, step.input, step.pin, False, 5.0)
        result.append(step)
    return [*result, Wait("hold at the end", 0.1)] if isinstance(result[-1], (Waypoint, RelativeWaypoint)) else result


def stopping(motion, brisk):
    """`motion` without a blend; `brisk`: its speed and acceleration (when set) at least a third of their range."""
    if not brisk:
        return Motion(motion.move, motion.speed, motion.acceleration)
    (_, v_high), (_, a_high) = motion_ranges(robot_model("ur3"), motion.move)   # the slowest arm's ranges
    return Motion(motion.move, None if motion.speed is None else max(motion.speed, v_high / 3),
                  None if motion.acceleration is None else max(motion.acceleration, a_high / 3))


def rich_program(seed, model):
    """The first random program from `seed` on with at least four waypoints, a linear or process one and a
    relative one, and an action."""
    for candidate in itertools.count(seed):
        _, steps = random_program(candidate, model, max_waypoints=5, max_actions=3)
        moves = [step.motion.move for step in steps if isinstance(step, (Waypoint, RelativeWaypoint))]
        if len(moves) >= 4 and set(moves) - {"joint"} and len(moves) < len(steps) and \
                any(isinstance(step, RelativeWaypoint) for step in steps):
            return steps
    raise AssertionError("unreachable")


def recorded_path(host, run):
    """The actual joints of every control cycle while `run()` runs, (N, 6): an RTDE stream read on a plain socket
    (sim_ursim streams every cycle, a late one too, and the kernel keeps what this reader has not read yet, so no
    cycle is lost however loaded the machine; ur_rtde's receiver keeps only the newest package)."""
    stream = socket.create_connection((host, 30004), timeout=10)
    stream.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
    buffer, samples, done = bytearray(), [], threading.Event()

    def package():
        while (found := protocol.split_package(buffer)) is None:
            chunk = stream.recv(1 << 16)
            assert chunk, "the simulator closed the RTDE stream"
            buffer.extend(chunk)
        del buffer[:found[2]]
        return found[0], found[1]

    def reply(request):
        stream.sendall(request)
        while (answer := package())[0] != request[2]:
            pass
        return answer[1]

    try:
        assert protocol.parse_accepted_reply(reply(protocol.pack_protocol_version_request(2)))
        _, types = protocol.parse_setup_outputs_reply(reply(protocol.pack_setup_outputs_request(["actual_q"], 500.0,
                                                                                              2)), 2)
        layout = protocol.recipe_struct(types)
        assert protocol.parse_accepted_reply(reply(protocol.pack_start_request()))

        def read():
            while not done.is_set():
                kind, payload = package()
                if kind == protocol.PackageType.DATA_PACKAGE:
                    samples.append(protocol.parse_data_package(payload, layout)[1])

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        run()
        time.sleep(0.2)
        done.set()
        reader.join(timeout=10)
    finally:
        stream.close()
    return np.array(samples)


def play(host, name):
    """Dashboard `load name` and `play`, as a pendant's operator would; returns once the program stopped."""
    import dashboard_client

    dashboard = dashboard_client.DashboardClient(host)
    dashboard.connect()
    try:
        dashboard.loadURP(name)
        assert dashboard.programState() == f"STOPPED {name}"
        dashboard.play()
        assert wait_for(lambda: dashboard.programState().startswith("PLAYING"), timeout=10)
        assert wait_for(lambda: dashboard.programState().startswith("STOPPED"), timeout=120)
    finally:
        dashboard.disconnect()


def assert_more_programs_play_as_planned(host, programs_dir, model_name, seed):
    """MORE_PROGRAMS further programs (brisk), each exported in this process on the connected arm's model as
    `export-urp --calibration robot` does, and played: the arm passes through the joints run-poses plans for it
    (plan_program from the arm's joints)."""
    from ur3dq.robot import connect

    with connect(host) as robot:
        model = robot.model
    for index in range(MORE_PROGRAMS):
        steps = playable(rich_program(1000 * seed + 100 * index, model_name), brisk=True)
        name = f"more_{index}"
        data = export_bytes(plan_program(model, steps, None, Defaults(), resolve_from=steps), steps, name, model)
        (programs_dir / f"{name}.urp").write_bytes(data)
        start = recorded_path(host, lambda: None)[-1]
        targets = [planned.joints for planned in plan_program(model, steps, start, Defaults(), resolve_from=steps)
                   if planned.joints is not None]
        assert_passes_through(recorded_path(host, lambda name=name: play(host, f"{name}.urp")), targets, name)


def assert_passes_through(path, targets, what):
    """`path` (N, 6) reaches every target (6,) in order, each within TOLERANCE rad on every joint."""
    at = 0
    for index, target in enumerate(targets):
        distance = np.max(np.abs(path[at:] - target), axis=1)
        hits = np.flatnonzero(distance <= TOLERANCE)
        assert hits.size, f"{what}: waypoint {index} {target.tolist()} missed by {distance.min():.3g} rad"
        at += int(hits[0])


@pytest.mark.timeout(400)
@pytest.mark.parametrize("model, seed, calibration, clock", [("ur3", 7, None, "fast"), ("ur5e", 11, None, "fast"),
                                                             ("ur5e", 23, CALIBRATION, "real-time")])
def test_a_played_urp_moves_the_arm_through_the_joints_run_poses_moves_it_through(run_cli, tmp_path, model, seed,
                                                                                 calibration, clock):
    from powered_simulator import powered_simulator

    steps = playable(rich_program(seed, model), brisk=True)
    PoseStore(tmp_path / "poses.json").update_program(lambda old: (steps, None))
    options = {"programs_dir": str(tmp_path), "initial_q": list(HOME), "clock": clock}   # the programs' IK branch
    if calibration:
        (tmp_path / "calibration.json").write_text(json.dumps(calibration))
        options["calibration"] = str(tmp_path / "calibration.json")
    with powered_simulator(model=model, **options) as simulator:
        host = ("--host", simulator.host)
        exported = run_cli(*host, "export-urp", "-o", "cell.urp", "--calibration", "robot", "--json")
        assert exported.returncode == 0, exported.stderr
        # the program sets each waypoint's own TCP, whatever the controller's is: --tcp recorded says so
        planned = run_cli(*host, "run-poses", "--dry-run", "--json", "--tcp", "recorded")
        assert planned.returncode == 0, planned.stderr
        targets = [np.array(step["joints"]) for step in json.loads(planned.stdout)["plan"] if step["joints"]]

        assert_passes_through(recorded_path(simulator.host, lambda: play(simulator.host, "cell.urp")), targets,
                              "the played .urp")

        imported = run_cli(*host, "--store", "imported.json", "import-urp", "cell.urp")
        assert imported.returncode == 0, imported.stderr
        assert f"cell.urp was saved on a {model.upper()} with the same kinematics as the connected" in imported.stderr
        if calibration:   # the calibrated arm's file: the same bytes again
            (tmp_path / "again").mkdir()
            again = run_cli(*host, "export-urp", "-o", "again/cell.urp", "--calibration", "robot")
            assert again.returncode == 0 and b'status="LINEARIZED"' in gzip.decompress((tmp_path / "cell.urp")
                                                                                       .read_bytes())
            assert (tmp_path / "again" / "cell.urp").read_bytes() == (tmp_path / "cell.urp").read_bytes()

        def run_poses():   # the program imported from the file: run as any other
            ran = run_cli(*host, "--store", "imported.json", "run-poses", "--yes", "--tcp", "recorded", timeout=180)
            assert ran.returncode == 0, ran.stderr

        assert_passes_through(recorded_path(simulator.host, run_poses), targets, "run-poses")
        assert_more_programs_play_as_planned(simulator.host, tmp_path, model, seed)
    assert len(targets) >= 2
