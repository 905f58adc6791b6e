"""Random programs exported as .urp, loaded and played by the simulator's dashboard (`load`, `play`) on a
fast-clock simulator: the arm passes, in order, through the joints `run-poses` moves it to at every waypoint where
it stops, within 1e-6 rad, and within the blend radius of every waypoint it blends past. The first PROGRAMS of the
200 programs of the export → import round trip (tests/polyscope/test_urp_round_trip.py) every run, about a minute;
UR3DQ_URP_PLAYBACK_PROGRAMS=200 plays all 200 (minutes: the simulator's per-cycle kinematics, not the clock, is then
what takes the time; figures in docs/performance.md).

The evidence is the simulator's own: its RTDE stream of every control cycle (actual_q, recorded on a plain socket),
from the cycle the program started in to the one it stopped in. The targets are the joints run-poses plans for the
program from where the arm stood (`plan_program`, what `run-poses --dry-run --json` prints and run-poses sends);
run-poses itself is not run here: its heartbeat and timeouts are wall-clock, and tests/cli/test_cli_urp_on_sim.py
ties the plan to run-poses' actual motion on a real-time simulator. A fast clock plays a program's simulated
seconds in a fraction of the time (docs/ursim.md).
"""
import dataclasses
import os

import numpy as np
import pytest

from dashboard_lines import LineClient
from rtde_recorder import RTDERecorder
from sim_ursim.vocabulary import RuntimeState
from ur3dq import dqarray
from ur3dq.kinematics import robot_model
from ur3dq.polyscope.urp_export import export_bytes
from ur3dq.program.plan import Defaults, motion_ranges, plan_program
from ur3dq.program.steps import Motion, RelativeWaypoint, Wait, WaitInput, Waypoint
from urp_programs import HOME, random_program

TOLERANCE = 1e-6
PROGRAMS = int(os.environ.get("UR3DQ_URP_PLAYBACK_PROGRAMS", "24"))   # of 200: seeds 0 .. PROGRAMS - 1
RECIPE = ["runtime_state", "actual_q"]


def playable(model, steps):
    """The program as it runs unattended, and briskly: waits of at most 50 ms, input waits the simulator's inputs
    (all off) satisfy, speeds and accelerations (where set) at least a third of their range (the targets do not
    depend on them; the time does); waypoints, blends, TCPs, outputs and messages as drawn."""
    result = []
    for step in steps:
        if isinstance(step, Wait):
            step = Wait(step.name, min(step.seconds, 0.05))
        elif isinstance(step, WaitInput):
            step = WaitInput(step.name, step.input, step.pin, False, step.timeout)
        elif isinstance(step, (Waypoint, RelativeWaypoint)):
            step = dataclasses.replace(step, motion=brisk(model, step.motion))
        result.append(step)
    return result


def brisk(model, motion):
    """`motion` with its speed and acceleration (when set) at least a third of their range."""
    (_, v_high), (_, a_high) = motion_ranges(model, motion.move)
    return Motion(motion.move, None if motion.speed is None else max(motion.speed, v_high / 3),
                  None if motion.acceleration is None else max(motion.acceleration, a_high / 3), motion.blend)


def played_path(dashboard, recorder, name):
    """Play program file `name`; (the joints where the arm stood before, (6,); the actual_q of every cycle from
    the one the program started in to the one it stopped in, (N, 6))."""
    first = len(recorder.rows)
    assert dashboard.ask(f"load {name}") == f"Loading program: {name}"
    assert dashboard.ask("play") == "Starting program"
    start = recorder.wait_for(lambda row: row[0] == RuntimeState.PLAYING, since=first)
    end = recorder.wait_for(lambda row: row[0] == RuntimeState.STOPPED, since=start, timeout=120)
    assert start > 0, "the recording holds no cycle before the program started"
    rows = recorder.rows
    return np.array(rows[start - 1][1:]), np.array([row[1:] for row in rows[start:end + 1]])


def assert_follows_the_plan(path, plan, model, what):
    """`path` (N, 6) reaches every stopping waypoint's joints in order within TOLERANCE rad, and passes within
    the blend radius (TCP, metres) of every waypoint it blends past."""
    at = 0
    for planned in plan:
        if planned.joints is None:
            continue
        if planned.blend == 0:
            distance = np.max(np.abs(path[at:] - planned.joints), axis=1)
            hits = np.flatnonzero(distance <= TOLERANCE)
            assert hits.size, f"{what}: {planned.step.name!r} missed by {distance.min():.3g} rad"
            at += int(hits[0])
        else:
            arm = model.with_tcp(planned.tcp_offset)
            aim = arm.fk(planned.joints).translation
            gaps = np.linalg.norm(dqarray.translation(arm.fk_batch(path[at:])) - aim, axis=1)
            hits = np.flatnonzero(gaps <= planned.blend + 1e-9)
            assert hits.size, (f"{what}: blended past {planned.step.name!r} {gaps.min():.4g} m away, "
                               f"blend {planned.blend:g} m")
            at += int(hits[0])


@pytest.mark.timeout(900)
@pytest.mark.parametrize("model_name", ["ur5e", "ur3"])
def test_exported_programs_play_through_the_joints_run_poses_moves_to(tmp_path, model_name):
    """As in the round trip, three programs in four on an e-series arm (gzip), one in four on a CB3 (plain XML)."""
    from powered_simulator import powered_simulator

    seeds = [seed for seed in range(min(PROGRAMS, 200)) if (seed % 4 != 0) == (model_name == "ur5e")]
    model = robot_model(model_name)
    kinds = set()
    with powered_simulator(model=model_name, programs_dir=str(tmp_path), initial_q=list(HOME), clock="fast") as sim:
        dashboard = LineClient(sim.host)
        with RTDERecorder(sim.host, RECIPE) as recorder:
            for seed in seeds:
                _, steps = random_program(seed, model_name)
                steps = playable(model, steps)
                name = f"program_{seed}.urp"
                exported = plan_program(model, steps, None, Defaults(), resolve_from=steps)
                (tmp_path / name).write_bytes(export_bytes(exported, steps, f"program_{seed}", model))
                start, path = played_path(dashboard, recorder, name)
                plan = plan_program(model, steps, start, Defaults(), resolve_from=steps)
                assert_follows_the_plan(path, plan, model, f"program {seed}")
                kinds |= {(type(s).__name__, s.motion.move, (s.motion.blend or 0) > 0) for s in steps
                          if isinstance(s, (Waypoint, RelativeWaypoint))}
        dashboard.close()
    assert {move for _, move, _ in kinds} == {"joint", "linear", "process"}
    assert any(blended for _, _, blended in kinds) and {kind for kind, _, _ in kinds} == {"Waypoint",
                                                                                          "RelativeWaypoint"}
