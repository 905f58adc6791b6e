"""An exported program played by the simulator's dashboard (`load`, `play`) moves the arm through the joints
`run-poses` plans (and, imported back, runs), at every waypoint within 1e-6 rad: random programs of every move
type, relative waypoints, outputs and waits, on a CB3 (plain XML), an e-series arm (gzip) and a calibrated one."""
import itertools
import json
import threading
import time

import numpy as np
import pytest

from polling import wait_for
from ur3dq.program.steps import Motion, RelativeWaypoint, Wait, WaitInput, Waypoint
from ur3dq.store import PoseStore
from urp_programs import HOME, random_program

TOLERANCE = 1e-6
# an arm off the catalogue by up to 0.4 mm and 0.6 mrad: the export carries its calibration, the pendant plays it
CALIBRATION = {"a": [0.0002, -0.0003, 0.0004, 0.0001, -0.0001, 0.0], "d": [0.0003, 0.0, 0.0, -0.0002, 0.0001, 0.0002],
               "alpha": [0.0005, -0.0003, 0.0002, 0.0006, -0.0004, 0.0], "theta": [0.0, 0.0004, -0.0002, 0.0003, 0.0,
                                                                                 -0.0001]}


def playable(steps):
    """The program with every waypoint stopping and held for 0.1 s (no blend: the arm rests on it, for the poll to
    see), short waits and input waits the simulator's inputs (all off) satisfy."""
    result = []
    for step in steps:
        if result and isinstance(result[-1], (Waypoint, RelativeWaypoint)):
            result.append(Wait(f"hold {len(result)}", 0.1))
        if isinstance(step, Waypoint):
            step = Waypoint(step.name, step.pose, Motion(step.motion.move, step.motion.speed,
                                                        step.motion.acceleration))
        elif isinstance(step, RelativeWaypoint):
            step = RelativeWaypoint(step.name, step.base, step.offset, step.frame,
                                    Motion(step.motion.move, step.motion.speed, step.motion.acceleration), step.note)
        elif isinstance(step, Wait):
            step = Wait(step.name, 0.02)
        elif isinstance(step, WaitInput):
            step = WaitInput(step.name, step.input, step.pin, False, 5.0)
        result.append(step)
    return [*result, Wait("hold at the end", 0.1)] if isinstance(result[-1], (Waypoint, RelativeWaypoint)) else result


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
    """The actual joints ur_rtde reads (polled every 2 ms) while `run()` runs."""
    import rtde_receive

    receive = rtde_receive.RTDEReceiveInterface(host)
    samples, done = [], threading.Event()

    def poll():
        while not done.is_set():
            samples.append(receive.getActualQ())
            time.sleep(0.002)

    poller = threading.Thread(target=poll, daemon=True)
    poller.start()
    try:
        run()
        time.sleep(0.2)
    finally:
        done.set()
        poller.join()
        receive.disconnect()
    return np.array(samples)


def assert_passes_through(path, targets, what):
    """`path` (N, 6) reaches every target (6,) in order, each within TOLERANCE rad on every joint."""
    at = 0
    for index, target in enumerate(targets):
        distance = np.max(np.abs(path[at:] - target), axis=1)
        hits = np.flatnonzero(distance <= TOLERANCE)
        assert hits.size, f"{what}: waypoint {index} {target.tolist()} missed by {distance.min():.3g} rad"
        at += int(hits[0])


@pytest.mark.timeout(400)
@pytest.mark.parametrize("model, seed, calibration", [("ur3", 7, None), ("ur5e", 11, None), ("ur5e", 23, CALIBRATION)])
def test_a_played_urp_moves_the_arm_through_the_joints_run_poses_moves_it_through(run_cli, tmp_path, model, seed,
                                                                                 calibration):
    from powered_simulator import powered_simulator

    steps = playable(rich_program(seed, model))
    PoseStore(tmp_path / "poses.json").update_program(lambda old: (steps, None))
    options = {"programs_dir": str(tmp_path), "initial_q": list(HOME)}   # the programs' IK branch
    if calibration:
        (tmp_path / "calibration.json").write_text(json.dumps(calibration))
        options["calibration"] = str(tmp_path / "calibration.json")
    with powered_simulator(model=model, **options) as simulator:
        host = ("--host", simulator.host)
        exported = run_cli(*host, "export-urp", "-o", "cell.urp", "--calibration", "robot", "--json")
        assert exported.returncode == 0, exported.stderr
        planned = run_cli(*host, "run-poses", "--dry-run", "--json")
        assert planned.returncode == 0, planned.stderr
        targets = [np.array(step["joints"]) for step in json.loads(planned.stdout)["plan"] if step["joints"]]

        def play():
            import dashboard_client

            dashboard = dashboard_client.DashboardClient(simulator.host)
            dashboard.connect()
            try:
                dashboard.loadURP("cell.urp")
                assert dashboard.programState() == "STOPPED cell.urp"
                dashboard.play()
                assert wait_for(lambda: dashboard.programState().startswith("PLAYING"), timeout=10)
                assert wait_for(lambda: dashboard.programState().startswith("STOPPED"), timeout=120)
            finally:
                dashboard.disconnect()

        assert_passes_through(recorded_path(simulator.host, play), targets, "the played .urp")

        imported = run_cli(*host, "--store", "imported.json", "import-urp", "cell.urp")
        assert imported.returncode == 0, imported.stderr

        def run_poses():   # the program imported from the file: run as any other
            ran = run_cli(*host, "--store", "imported.json", "run-poses", "--yes", timeout=180)
            assert ran.returncode == 0, ran.stderr

        assert_passes_through(recorded_path(simulator.host, run_poses), targets, "run-poses")
    assert len(targets) >= 2
