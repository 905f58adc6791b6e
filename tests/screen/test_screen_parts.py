"""The screen's parts without a browser: the page's edits with undo/redo through the store, what the page shows in
the user's units, who may open it, and `ur3dq serve`'s refusals."""
import ast
import math
import socket
import subprocess
import sys

import numpy as np
import pytest

from ur3dq import units as u
from ur3dq.errors import StoreError
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.program.steps import Motion, RelativeWaypoint, Wait, Waypoint
from ur3dq.screen import editing, views
from ur3dq.screen.access import is_loopback, request_allowed, token_accepted
from ur3dq.screen.operations import typed_motion
from ur3dq.store import PoseStore

UR3 = robot_model("ur3")
Q = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0])
DEG_MM = u.Units(angle="deg", length="mm")


def pose(name: str, dq: float = 0.0) -> Pose:
    q = Q + np.array([dq, 0, 0, 0, 0, 0])
    return Pose.from_dual_quaternion(name, UR3.fk(q), "ur3", joints=tuple(q))


@pytest.fixture
def store(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    store.add_many([pose("a"), pose("b", 0.2), pose("c", 0.4)])
    return store


def names(store: PoseStore) -> list[str]:
    return [step.name for step in store.load_program()]


def test_edits_go_through_the_store_and_undo_redo_them(store):
    editor = editing.ProgramEditor(store)
    editor.apply("add a wait", editing.insert_step(lambda taken: Wait("wait-1", 0.5), "a"))
    editor.apply("move c up", editing.move_step("c", -1))
    editor.apply("rename b", editing.rename_step("b", "place"))
    assert names(store) == ["a", "wait-1", "c", "place"]
    assert editor.undo() == "rename b" and names(store) == ["a", "wait-1", "c", "b"]
    assert editor.undo() == "move c up" and names(store) == ["a", "wait-1", "b", "c"]
    assert editor.redo() == "move c up" and names(store) == ["a", "wait-1", "c", "b"]
    assert editor.state()["can_undo"] and editor.state()["can_redo"]
    editor.apply("delete wait", editing.delete_step("wait-1"))   # a new edit ends the redo history
    assert not editor.state()["can_redo"]
    with pytest.raises(StoreError, match="nothing to redo"):
        editor.redo()


def test_undo_never_loses_an_edit_made_elsewhere(store):
    editor = editing.ProgramEditor(store)
    editor.apply("delete b", editing.delete_step("b"))
    PoseStore(store.path).rename("c", "place")        # the command line, meanwhile
    with pytest.raises(StoreError, match="changed since"):
        editor.undo()
    assert names(store) == ["a", "place"]             # both edits are still there
    assert editor.state()["can_undo"]


def test_the_last_fifty_edits_can_be_undone(store):
    editor = editing.ProgramEditor(store)
    for number in range(editing.MAX_UNDO + 5):
        editor.apply(f"wait {number}", editing.insert_step(lambda taken, n=number: Wait(f"wait-{n}", 0.1), None))
    for _ in range(editing.MAX_UNDO):
        editor.undo()
    assert not editor.state()["can_undo"]
    assert names(store) == ["a", "b", "c"] + [f"wait-{n}" for n in range(5)]


def test_a_bad_edit_changes_nothing_and_is_not_remembered(store):
    editor = editing.ProgramEditor(store)
    store.update_program(lambda steps: (steps + [RelativeWaypoint("above-a", "a", (0, 0, -0.05, 0, 0, 0))], None))
    before = store.path.read_text()
    with pytest.raises(ValueError, match="above-a"):
        editor.apply("delete a", editing.delete_step("a"))       # a relative waypoint is based on it
    with pytest.raises(ValueError, match="already the first"):
        editor.apply("move a up", editing.move_step("a", -1))
    assert store.path.read_text() == before and not editor.state()["can_undo"]


def test_steps_are_shown_in_the_pages_units():
    joint = Waypoint("a", pose("a"), Motion("joint", speed=math.radians(60), blend=0.02))
    line = Waypoint("b", pose("b"), Motion("linear", speed=0.25))
    relative = RelativeWaypoint("above", "a", (0.0, 0.0, -0.05, 0.0, 0.0, 0.0))
    assert views.step_row(joint, DEG_MM)["speed"] == "60 °/s"
    assert views.step_row(joint, DEG_MM)["blend"] == "20 mm"
    assert views.step_row(joint, u.Units())["speed"] == "1.0472 rad/s"
    assert views.step_row(line, DEG_MM)["speed"] == "250 mm/s" and views.step_row(line, DEG_MM)["blend"] == "default"
    assert views.step_row(relative, DEG_MM)["details"] == "from a (tool frame): 0 mm, 0 mm, -50 mm"
    assert views.readout(math.radians(12.3456), u.ANGLE, DEG_MM) == "12.35 °"
    assert views.readout(0.123456, u.LENGTH, u.Units()) == "0.1235 m"


def test_a_checks_problems_are_shown_in_the_pages_units():
    message = {"problems": [{"step": "a", "line": "…", "tcp": [-0.399, -0.118, 0.03], "check": "cell",
                             "fraction": 1.0, "message": 'wrist 3 capsule 82 mm inside keep-out box "table"',
                             "hint": "add a waypoint"}], "smallest_clearance": -0.0919622}
    shown = views.check_for_page(message, DEG_MM)
    assert shown["problems"][0]["line"] == ("step 'a' at 100% of the move (TCP -399.0, -118.0, 30.0 mm): wrist 3 "
                                            'capsule 82 mm inside keep-out box "table"; add a waypoint')
    assert shown["smallest"] == "smallest clearance -92.0 mm"
    assert views.check_for_page(message, u.Units())["smallest"] == "smallest clearance -0.0920 m"


def test_a_real_checks_numbers_are_shown_in_each_pages_units_and_refuse_a_run_in_them():
    from ur3dq.errors import SafetyCheckError
    from ur3dq.pathcheck import Margins, PathPlan, PathSegment, check_path

    q = [0.0, -1.2, 1.5, -1.8, 0.3, 0.5]
    margin = 2 * math.pi - 1.0   # keeps every joint within ±1 rad: wrist 1 at -1.8 rad fails it by the most
    result = check_path(UR3, PathPlan(q, [PathSegment("stay", "joint", target_joints=q)]),
                        margins=Margins(joint_limit=margin))
    assert [p.check for p in result.problems] == ["joint_limit"], result.summary()
    message = views.check_message(result, UR3, None, Margins())
    shown = views.check_for_page(message, DEG_MM)
    problem = shown["problems"][0]
    said = (f"joint 4 (wrist 1) at {math.degrees(-1.8):.2f} ° passes its limit [-360.00, 360.00] (margin "
            f"{math.degrees(margin):.1f} °)")
    assert problem["message"] == said
    x, y, z = (1000 * v for v in result.problems[0].tcp)
    assert problem["line"].startswith(f"step 'stay' at 0% of the move (TCP {x:.1f}, {y:.1f}, {z:.1f} mm): {said}")
    assert "measured" not in problem and "refusal" not in shown
    assert views.check_for_page(message, u.Units())["problems"][0]["message"] == \
        "joint 4 (wrist 1) at -1.8000 rad passes its limit [-6.2832, 6.2832] (margin 5.283 rad)"
    text, measured = message["refusal"]
    refusal = SafetyCheckError.from_wording("path check: " + text, measured)
    assert "at -1.8000 rad passes" in str(refusal) and f"{said}; use targets" in str(refusal.shown_in(DEG_MM))
    assert f"(TCP {x:.1f}, {y:.1f}, {z:.1f} mm)" in str(refusal)   # the run's refusal writes the TCP as the check


def test_typed_speeds_and_blends_are_read_in_the_pages_units():
    def typed(fields):
        return typed_motion("p", fields, DEG_MM, UR3)(Motion())

    motion = typed({"move": "linear", "speed": "250", "blend": "5"})
    assert (motion.move, motion.speed, motion.blend) == ("linear", pytest.approx(0.25), pytest.approx(0.005))
    motion = typed({"move": "joint", "speed": "60", "blend": ""})
    assert motion.speed == pytest.approx(math.radians(60)) and motion.blend is None
    assert typed({"move": "joint", "speed": "0.5rad/s"}).speed == pytest.approx(0.5)
    with pytest.raises(ValueError, match="'mm/s' is a unit of linear speed"):
        typed({"move": "joint", "speed": "250mm/s"})


def test_the_motion_editor_keeps_the_acceleration_and_checks_the_range():
    linear = Motion("linear", 0.1, 0.5, None)
    assert typed_motion("p", {"move": "linear", "speed": "100", "blend": "2"}, DEG_MM, UR3)(linear).acceleration == 0.5
    assert typed_motion("p", {"move": "joint"}, DEG_MM, UR3)(linear).acceleration is None   # another kind
    for speed in ("1e300", "1e-9", "0.5"):
        with pytest.raises(ValueError, match=r"waypoint 'p': speed .* is outside the ur3's range for a linear move, "
                                             r"1 mm/s to 1000 mm/s$"):
            typed_motion("p", {"move": "linear", "speed": speed}, DEG_MM, UR3)(linear)


def test_only_loopback_is_open_without_a_token():
    assert is_loopback("127.0.0.1") and is_loopback("127.4.5.6") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.10") and not is_loopback("cell-pc")
    assert token_accepted(None, None)
    assert token_accepted("s3cret-token-1", "s3cret-token-1")
    assert not token_accepted("s3cret-token-1", None) and not token_accepted("s3cret-token-1", "s3cret-token-2")


def test_only_the_screens_own_page_may_open_its_websocket():
    assert request_allowed("127.0.0.1:8765", "http://127.0.0.1:8765", False)
    assert request_allowed("localhost:8765", None, False)                        # no browser: no Origin
    assert not request_allowed("127.0.0.1:8765", "http://shop.example", False)   # another site in the browser
    assert not request_allowed("rebound.example:8765", "http://rebound.example:8765", False)   # DNS rebinding
    assert request_allowed("10.0.0.5:8765", "http://10.0.0.5:8765", True)         # off loopback, with the token
    assert not request_allowed("10.0.0.5:8765", "http://10.0.0.6:8765", True)


def serve(tmp_path, *arguments: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ur3dq", "--store", str(tmp_path / "p.json"), "serve", *arguments],
                          capture_output=True, text=True, timeout=60, env={"UR3DQ_STATE_DIR": str(tmp_path)})


def test_serve_refuses_other_machines_without_a_token_and_a_taken_port(tmp_path):
    refused = serve(tmp_path, "--bind", "0.0.0.0")
    assert refused.returncode == 2 and "--bind 0.0.0.0 lets other machines open the page" in refused.stderr
    assert "--token" in refused.stderr.splitlines()[-1]
    short = serve(tmp_path, "--bind", "127.0.0.1", "--token", "abc")
    assert short.returncode == 2 and "at least 12 characters" in short.stderr
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        busy = serve(tmp_path, "--port", str(taken.getsockname()[1]))
    assert busy.returncode == 2 and "cannot listen on 127.0.0.1" in busy.stderr.splitlines()[-1]


def test_the_command_line_does_not_load_the_web_stack(tmp_path):
    code = ("import sys; from ur3dq.cli import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('starlette', 'uvicorn', 'websockets')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert done.stdout.strip().splitlines()[-1] == "[]"


def test_serve_starts_without_the_other_commands_and_rich():
    code = ("import sys; from ur3dq.cli import main\n"
            "try:\n    main(['serve', '--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'rich' or m.startswith('ur3dq.cli.')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    loaded = ast.literal_eval(done.stdout.strip().splitlines()[-1])
    assert loaded == ["ur3dq.cli.app", "ur3dq.cli.background_simulator", "ur3dq.cli.library_output",
                      "ur3dq.cli.options", "ur3dq.cli.serve", "ur3dq.cli.signals"]


def test_a_jog_button_is_the_drivers_jog_step_with_the_keyboards_step_sizes():
    from ur3dq.robot import jog_steps
    from ur3dq.screen.server import ScreenServer

    held, speed = ScreenServer._jog_request({"axis": "J1", "direction": 1, "step": 0, "speed": 0.2})
    assert held == jog_steps.JogStep("J1", 1) and held.held
    assert speed == pytest.approx(0.2 * jog_steps.MAX_JOINT_SPEED)
    step, speed = ScreenServer._jog_request({"axis": "Z", "direction": -1, "frame": "tool", "step": 2, "speed": 1})
    assert step == jog_steps.JogStep("Z", -1, 0.001, "tool") and speed == jog_steps.MAX_TCP_SPEED   # 1 mm, top speed
    turn, _ = ScreenServer._jog_request({"axis": "RX", "direction": 1, "step": 3, "speed": 0.5})
    assert turn.size == pytest.approx(math.radians(jog_steps.STEP_SIZES[2]))
    with pytest.raises(ValueError, match="jog speed"):
        ScreenServer._jog_request({"axis": "J1", "speed": 2})
    with pytest.raises(ValueError, match="jog step"):
        ScreenServer._jog_request({"axis": "J1", "step": 9})
    with pytest.raises(ValueError, match="axis 'J7'"):
        ScreenServer._jog_request({"axis": "J7"})


@pytest.mark.parametrize("calibrated", [False, True])
def test_the_live_arm_is_placed_where_the_path_check_places_it(calibrated):
    from calibrated_arms import factory_model, random_configurations
    from ur3dq.pathcheck import ToolShape
    from ur3dq.pathcheck.geometry import capsule_points, dh_frames
    from ur3dq.screen.scene import ArmShape

    model = (factory_model("ur5e", 3) if calibrated else UR3).with_tcp([0.0, 0.01, 0.12, 0.0, 0.0, 0.3])
    shape = ArmShape(model, ToolShape.capsule([0, 0, 0], [0, 0, 0.1], 0.03))
    for q in random_configurations(20, 5):
        placed = shape.placed(q)
        a, b = capsule_points(dh_frames(model, q[None]), shape.capsules)
        np.testing.assert_allclose(placed["capsules"], np.concatenate([a[0], b[0]], axis=1), atol=1e-6)
        np.testing.assert_allclose(np.reshape(placed["tcp"], (4, 4)).T, model.fk(q).to_matrix(), atol=1e-6)


def test_the_live_arm_is_drawn_without_the_compiled_kernels():
    # The page's first arm waits for nothing the first drawing does not need: numba and the kernels' cache load
    # in the background, for planning.
    code = ("import sys, numpy as np; from ur3dq.kinematics import robot_model; from ur3dq.screen.scene import "
            "ArmShape; import ur3dq.screen.server; ArmShape(robot_model('ur3')).placed(np.zeros(6)); "
            "print(sorted(m for m in ('numba', 'ur3dq.kinematics.fk', 'rich') "
            "if m in sys.modules))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert loaded.strip() == "[]"
