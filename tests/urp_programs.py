"""Random cell programs for the .urp round trip (seeded: the same programs every run), and what a program looks
like once exported and imported again (the plan's speeds, blends and joints written into it)."""
import dataclasses
import string

import numpy as np

from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.program.plan import Defaults, motion_ranges, plan_program
from ur3dq.program.steps import (
    MAX_WAIT_S,
    AnalogOut,
    Comment,
    DigitalOut,
    Message,
    Motion,
    RelativeWaypoint,
    Wait,
    WaitInput,
    Waypoint,
)

HOME = np.array([0.3, -1.3, 1.4, -1.7, -1.57, 0.4])   # elbow and wrist well away from their singularities
TCP_OFFSETS = [(0.0,) * 6, (0.0, 0.0, 0.12, 0.0, 0.0, 0.0), (0.01, -0.02, 0.15, 0.1, -0.2, 0.3)]
NAME_CHARACTERS = string.ascii_letters + string.digits + " -_./'\"<>&:;=[]()é°ü"
# names that are the pendant's label of a node (the export leaves those nodes bare) and free text
LABEL_NAMES = ["Wait 0.5", "Set tool_out[0]=On", "Set digital_out[3]=Off", "Wait digital_in[2]=HI", "Popup: hello",
               "a comment"]
MOVES = ("joint", "linear", "process")
OUTPUTS = ("standard", "configurable", "tool")


def text(rng, low=1, high=30):
    """Free text: quotes, markup, non-ASCII, slashes; no leading or trailing blanks."""
    size = int(rng.integers(low, high + 1))
    return "".join(rng.choice(list(NAME_CHARACTERS), size)).strip() or "x"


def unique_names(rng, count):
    names = []
    while len(names) < count:
        name = str(rng.choice(LABEL_NAMES)) if rng.random() < 0.2 else text(rng)
        if name not in names:
            names.append(name)
    return names


def motion(rng, model, move):
    """A Motion of `move`, each value unset or in the model's range; blends unset, zero or up to 5 cm."""
    (v_low, v_high), (a_low, a_high) = motion_ranges(model, move)
    speed = None if rng.random() < 0.4 else float(rng.uniform(v_low, v_high))
    acceleration = None if rng.random() < 0.4 else float(rng.uniform(a_low, a_high))
    blend = [None, 0.0, float(rng.uniform(0, 0.05))][int(rng.integers(3))]
    return Motion(move, speed, acceleration, blend)


def action(rng, name):
    """Any action or comment step called `name`."""
    kind = str(rng.choice(OUTPUTS))
    pin = int(rng.integers(2 if kind == "tool" else 8))
    choice = int(rng.integers(6))
    if choice == 0:
        return DigitalOut(name, kind, pin, bool(rng.integers(2)))
    if choice == 1:
        return AnalogOut(name, int(rng.integers(2)), float(rng.uniform(0, 1)))
    if choice == 2:
        return Wait(name, 0.5 if rng.random() < 0.3 else float(rng.uniform(0.001, 100)))
    if choice == 3:
        timeout = MAX_WAIT_S if rng.random() < 0.3 else float(rng.uniform(0.1, 600))
        return WaitInput(name, kind, pin, bool(rng.integers(2)), timeout)
    if choice == 4:
        return Message(name, text(rng, 1, 60))
    return Comment(name, name if rng.random() < 0.5 else text(rng, 0, 60))


def random_program(seed, model_name="ur5e", max_waypoints=6, max_actions=5):
    """(model, steps) of program `seed`: waypoints of every move type (recorded joints near HOME, a TCP offset,
    a note), relative waypoints (tool and base frame, on any waypoint before or after them), every action and
    comments, in a random order."""
    rng = np.random.default_rng(seed)
    model = robot_model(model_name)
    count, relative_count = int(rng.integers(1, max_waypoints + 1)), int(rng.integers(0, 3))
    action_count = int(rng.integers(0, max_actions + 1))
    names = unique_names(rng, count + relative_count + action_count)
    waypoints = []
    for name in names[:count]:
        q = HOME + rng.uniform(-0.3, 0.3, 6)
        tcp = TCP_OFFSETS[int(rng.integers(len(TCP_OFFSETS)))]
        note = "" if rng.random() < 0.6 else text(rng)
        pose = Pose.from_dual_quaternion(name, model.with_tcp(tcp).fk(q), model_name,
                                         joints=tuple(float(v) for v in q), tcp_offset=tcp, note=note)
        waypoints.append(Waypoint(name, pose, motion(rng, model, str(rng.choice(MOVES)))))
    relatives = []
    for name in names[count:count + relative_count]:
        bases = waypoints + relatives
        base = bases[int(rng.integers(len(bases)))].name
        offset = tuple(float(v) for v in rng.uniform(-0.04, 0.04, 6))
        relatives.append(RelativeWaypoint(name, base, offset, str(rng.choice(["tool", "base"])),
                                          motion(rng, model, str(rng.choice(MOVES))),
                                          "" if rng.random() < 0.6 else text(rng)))
    actions = [action(rng, name) for name in names[count + relative_count:]]
    steps = waypoints + relatives + actions
    return model, [steps[i] for i in rng.permutation(len(steps))]


def plan_of(model, steps, replay_joints=False):
    """The plan export-urp writes (the nominal model, the run's default speeds, no start)."""
    return plan_program(model, steps, None, Defaults(), replay_recorded_joints=replay_joints, resolve_from=steps)


def as_exported(plan):
    """The program an export of `plan` re-imports as: a waypoint's own speed and acceleration as planned
    (clamped), its blend as planned where it sets one or the plan blends it, its joints the planned ones."""
    result = []
    for planned in plan:
        step = planned.step
        if planned.move is None:
            result.append(step)
            continue
        own = step.motion
        motion = Motion(own.move, planned.speed if own.speed is not None else None,
                        planned.acceleration if own.acceleration is not None else None,
                        planned.blend if own.blend is not None or planned.blend > 0 else None)
        if isinstance(step, Waypoint):
            pose = dataclasses.replace(step.pose, joints=tuple(planned.joints.tolist()))
            result.append(Waypoint(step.name, pose, motion))
        else:
            result.append(RelativeWaypoint(step.name, step.base, step.offset, step.frame, motion, step.note))
    return result


def assert_same_program(imported, expected, tolerance=1e-9, seed=None):
    """The two programs are the same step for step; recorded poses within `tolerance` (m, rad), joints exact,
    the recording time aside (an import is a new recording)."""
    assert [(s.kind, s.name) for s in imported] == [(s.kind, s.name) for s in expected], seed
    for got, want in zip(imported, expected):
        if isinstance(want, Waypoint):
            assert got.motion == want.motion, (seed, got.name, got.motion, want.motion)
            mine, theirs = got.pose, want.pose
            assert (mine.robot_model, mine.tcp_offset, mine.note) == (theirs.robot_model, theirs.tcp_offset,
                                                                      theirs.note), (seed, got.name)
            assert mine.joints == theirs.joints, (seed, got.name)
            metres, radians = mine.dq.distance(theirs.dq)
            assert metres <= tolerance and radians <= tolerance, (seed, got.name, metres, radians)
        else:
            assert got == want, (seed, got, want)
