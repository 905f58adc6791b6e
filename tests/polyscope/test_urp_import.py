"""import of PolyScope programs: what maps to a step, and every node without one refused by its place in the tree
(or kept as PolyScope's URScript with keep_script)."""
import math

import numpy as np
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.polyscope.urp_file import UrpFileError, parse_urp_bytes
from ur3dq.polyscope.urp_import import UnsupportedNodes, import_program
from ur3dq.program.resolve import resolve_targets
from ur3dq.program.steps import (
    MAX_WAIT_S,
    Comment,
    DigitalOut,
    KeptScript,
    Message,
    Motion,
    RelativeWaypoint,
    Wait,
    WaitInput,
    Waypoint,
)
from urp_samples import (
    CB3_WAIT_PROGRAM,
    E_SERIES_EXTERNAL_CONTROL,
    E_SERIES_WAIT_PROGRAM,
    HOME,
    expression,
    folder,
    move,
    position,
    set_digital,
    tree,
    waypoint,
)

UR5E = robot_model("ur5e")
DIGITAL_IN_0 = '<expression><ExpressionIO><pin referencedName="digital_in[0]"/></ExpressionIO></expression>'
SLEEP = '<Wait type="Sleep"><waitTime>0.1</waitTime></Wait>'


@pytest.mark.parametrize("xml, model, serial", [(E_SERIES_WAIT_PROGRAM, "ur5e", "e"), (CB3_WAIT_PROGRAM, "ur5", "3")])
def test_urcl_s_wait_program_is_one_wait_on_its_arm(xml, model, serial):
    imported = import_program(parse_urp_bytes(xml.encode(), "wait_program.urp"))
    assert imported.steps == [Wait("Wait 0.01", 0.01)]
    assert imported.model.name == model and not imported.model.calibrated
    assert any("loops forever on the pendant" in line for line in imported.warnings)


def test_urcl_s_external_control_program_is_refused_by_its_urcap_node_even_when_keeping_script():
    for keep in (False, True):
        with pytest.raises(UnsupportedNodes, match=r"external_control.urp: 1 node without a ur3dq step: "
                                                   r"Robot Program/External Control \("):
            import_program(parse_urp_bytes(E_SERIES_EXTERNAL_CONTROL.encode(), "external_control.urp"),
                           keep_script=keep)


def test_moves_waypoints_outputs_waits_popups_comments_and_folders_become_steps():
    tcp = (0.0, 0.0, 0.1, 0.0, 0.0, 0.0)
    q2 = tuple(v + 0.1 for v in HOME)
    main = (move("MoveJ", waypoint("pick", HOME, tcp), '<Comment comment="then up"/>',
                 waypoint("up", q2, tcp, 'jointSpeed="0.5" blendRadius="0.02"'))
            + folder("Gripper", set_digital("tool_out[0]"), '<Wait type="Sleep"><waitTime>0.5</waitTime></Wait>')
            + folder("close", set_digital("digital_out[3]", False))
            + '<Wait type="DigitalInput"><pin referencedName="config_in[2]"/><digitalValue>1</digitalValue></Wait>'
            + '<Popup type="Message" message="cycle done" haltProgram="false"/>'
            + move("MoveL", waypoint("place", HOME, tcp), speed="0.25", acceleration="1.2",
                   extra='positionType="CartesianPose"'))
    imported = import_program(tree(main))
    steps = imported.steps
    assert [(s.kind, s.name) for s in steps] == [
        ("waypoint", "pick"), ("comment", "then up"), ("waypoint", "up"), ("comment", "Gripper"),
        ("digital-out", "Set tool_out[0]=On"), ("wait", "Wait 0.5"), ("digital-out", "close"),
        ("wait-input", "Wait config_in[2]=HI"), ("message", "Popup: cycle done"), ("waypoint", "place")]
    assert steps[0].motion == Motion("joint", 1.0, 1.2, 0.0)
    assert steps[2].motion == Motion("joint", 0.5, 1.2, 0.02)
    assert steps[9].motion == Motion("linear", 0.25, 1.2, 0.0)
    assert steps[4] == DigitalOut("Set tool_out[0]=On", "tool", 0, True)
    assert steps[6] == DigitalOut("close", "standard", 3, False)
    assert steps[7] == WaitInput("Wait config_in[2]=HI", "configurable", 2, True, MAX_WAIT_S)
    assert steps[8] == Message("Popup: cycle done", "cycle done")
    pick = steps[0].pose
    assert pick.joints == HOME and pick.tcp_offset == tcp and pick.robot_model == "ur5e"
    assert pick.dq.is_close(UR5E.with_tcp(tcp).fk(HOME), 1e-12, 1e-12)
    assert any("waits for the input for ever" in line for line in imported.warnings)
    assert any("waits for the operator at a popup" in line for line in imported.warnings)


def test_a_polyscope_relative_waypoint_lands_where_polyscope_puts_it():
    """PolyScope moves a relative waypoint by pose_add(previous target, pose_sub(to, from)): positions added,
    rotations composed previous.R · from.R⁻¹ · to.R."""
    start, end = (0.1, -1.4, 1.5, -1.6, -1.5, 0.2), (0.2, -1.3, 1.4, -1.8, -1.4, 0.5)
    relative = ('<Waypoint type="Relative" name="nudge"><motionParameters/>'
                f'{position(start, tag="fromPosition")}{position(end, tag="toPosition")}</Waypoint>')
    steps = import_program(tree(move("MoveL", waypoint("pick"), relative))).steps
    assert isinstance(steps[1], RelativeWaypoint) and steps[1].base == "pick" and steps[1].frame == "base"
    got = resolve_targets(steps)["nudge"].pose
    previous, first, second = (_matrix(UR5E.fk(q)) for q in (HOME, start, end))
    rotation = previous[:3, :3] @ first[:3, :3].T @ second[:3, :3]
    translation = previous[:3, 3] + second[:3, 3] - first[:3, 3]
    want = _matrix(got)
    assert np.allclose(want[:3, :3], rotation, atol=1e-12) and np.allclose(want[:3, 3], translation, atol=1e-12)


def _matrix(dq):
    pose = dq.to_ur_pose()
    angle = float(np.linalg.norm(pose[3:]))
    axis = pose[3:] / angle if angle else np.zeros(3)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    result = np.eye(4)
    result[:3, :3] = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
    result[:3, 3] = pose[:3]
    return result


def test_a_folder_of_one_node_names_it_and_folders_nest_flat():
    main = folder("Outer", folder("Inner", set_digital("digital_out[1]")), SLEEP, '<Placeholder/>')
    steps = import_program(tree(main)).steps
    assert [(s.kind, s.name) for s in steps] == [("comment", "Outer"), ("digital-out", "Inner"),
                                                 ("wait", "Wait 0.1")]
    assert steps[0] == Comment("Outer", "Outer")


def test_names_stay_unique_against_the_program_and_the_store():
    main = move("MoveJ", waypoint("pick"), waypoint("pick")) + SLEEP + SLEEP
    imported = import_program(tree(main), taken=["Wait 0.1"])
    assert [s.name for s in imported.steps] == ["pick", "pick-1", "Wait 0.1-1", "Wait 0.1-2"]
    assert any("the name 'pick' is taken; imported as 'pick-1'" in line for line in imported.warnings)


def test_a_calibrated_arm_s_program_is_read_with_its_calibration():
    """A UR10e's factory calibration as PolyScope saved it (hundreds of metres in cancelling d2/d3 offsets)."""
    kinematics = """<kinematics status="LINEARIZED" validChecksum="true">
      <deltaTheta value="-8.844411260213857E-8, -0.032582961261549755, -0.8772929446404238, 0.9098787703504071, \
2.101429764675086E-6, -1.9523604853220917E-7"/>
      <a value="1.2280920183406098E-4, -0.6118328650166482, -0.35064142434212725, 6.353071874199852E-5, \
-8.491717228743712E-5, 0.0"/>
      <d value="0.18107019996630838, -11.986107840354439, 254.02185121292118, -241.86139249326118, \
0.11978728860232488, 0.11569307278026907"/>
      <alpha value="1.570573614624119, 0.0016638537326948237, -0.0018631164519257151, 1.5706607381785331, \
-1.5704473543987978, 0.0"/>
      <jointChecksum value="-1858852621, -1856465696, 659529794, -1323325273, -1859399821, -1861357583"/>
    </kinematics>"""
    q = (1.9942498207092285, -1.6684614620604457, 1.9330504576312464, -0.2718423169902344, 1.3209004402160645,
         0.0036344528198242188)
    imported = import_program(tree(move("MoveJ", waypoint("Waypoint_1", q)), kinematics=kinematics))
    assert imported.model.name == "ur10e" and imported.model.calibrated
    pose = imported.steps[0].pose
    assert pose.dq.is_close(imported.model.fk(q), 1e-12, 1e-12)
    metres, _ = pose.dq.distance(robot_model("ur10e").fk(q))
    assert 1e-4 < metres < 0.02   # the calibration moves the TCP by millimetres


def test_a_polyscope_3_position_gives_the_tcp_offset_its_pose_implies():
    tcp = (0.0, 0.0, 0.15, 0.0, 0.0, 0.0)
    pose = [float(v) for v in UR5E.with_tcp(tcp).fk(HOME).to_ur_pose()]
    wp = (f'<Waypoint type="Fixed" name="old"><motionParameters/><position joints="{", ".join(map(repr, HOME))}" '
          f'pose="{", ".join(map(repr, pose))}"/></Waypoint>')
    step = import_program(tree(move("MoveJ", wp))).steps[0]
    assert np.allclose(step.pose.tcp_offset, tcp, atol=1e-9) and step.pose.joints == HOME


def test_an_installation_s_pin_names_are_read_back_to_polyscope_s(tmp_path):
    import gzip

    from ur3dq.polyscope.urp_file import installation_pin_aliases, read_urp
    from urp_samples import program_xml

    (tmp_path / "cell.urp").write_bytes(gzip.compress(program_xml(set_digital("gripper")).encode()))
    (tmp_path / "default.installation").write_bytes(gzip.compress(
        b'<Installation><IOs><ToolDigitalOutputNames value="gripper, "/></IOs></Installation>'))
    program = read_urp(tmp_path / "cell.urp")
    aliases = installation_pin_aliases(program, tmp_path / "cell.urp")
    assert aliases == {"gripper": "tool_out[0]"}
    assert import_program(program, pin_aliases=aliases).steps == [DigitalOut("Set tool_out[0]=On", "tool", 0, True)]
    with pytest.raises(UnsupportedNodes, match=r"Robot Program/Set \(I/O pin 'gripper' is neither"):
        import_program(program)


IF_CHAIN = (f'<If type="If" checkContinuously="false">{DIGITAL_IN_0}<children>{SLEEP}</children></If>'
            f'<If type="ElseIf">{expression("x > 2")}<children>{set_digital("digital_out[2]")}</children></If>'
            f'<If type="Else"><children><Halt/></children></If>')
UNSUPPORTED = {
    "If": (f'<If type="If" checkContinuously="false">{DIGITAL_IN_0}<children>{SLEEP}</children></If>',
           "Robot Program/Folder 2/If digital_in[0]", ["if (get_standard_digital_in(0)):", "  sleep(0.1)", "end"]),
    "If ElseIf Else": (IF_CHAIN, "Robot Program/Folder 2/If digital_in[0]",
                       ["elif (x > 2):", "  set_standard_digital_out(2, True)", "else:", "  halt"]),
    "Loop while": (f'<Loop type="While" checkContinuously="false">{expression("x<5")}<children>{SLEEP}</children>'
                   "</Loop>", "Robot Program/Folder 2/Loop x<5", ["while (x<5):", "  sleep(0.1)"]),
    "Loop forever": (f'<Loop type="Forever"><children>{SLEEP}</children></Loop>', "Robot Program/Folder 2/Loop",
                     ["while (True):"]),
    "Loop counted": (f'<Loop type="Counting" count="3"><children>{SLEEP}</children></Loop>',
                     "Robot Program/Folder 2/Loop 3 times", ["Loop_1 = 0", "while (Loop_1 < 3):",
                                                             "  Loop_1 = Loop_1 + 1"]),
    "Script line": (f'<Script type="Line">{expression("textmsg(1)")}</Script>', "Robot Program/Folder 2/textmsg(1)",
                    ["textmsg(1)"]),
    "Script file": ('<Script type="File"><cachedContents>def helper():\n\tsync()\nend\n</cachedContents>'
                    "<file>/programs/helper.script</file></Script>", "Robot Program/Folder 2/Script: helper.script",
                    ["def helper():", "  sync()"]),
    "Assignment": (f'<Assignment valueSource="Expression"><variable name="count"/>{expression("0")}</Assignment>',
                   "Robot Program/Folder 2/count:=0", ["global count=0"]),
    "Sub-program call": ('<CallSubProgram><subprogram name="Sub"><children>'
                         f"{SLEEP}</children></subprogram></CallSubProgram>", "Robot Program/Folder 2/Call Sub",
                         ["def Sub():", "  sleep(0.1)", "Sub()"]),
    "Variable waypoint": (move("MoveL", '<Waypoint type="Variable" name="Waypoint_1"><motionParameters/>'
                               '<variable name="target"/></Waypoint>'),
                          "Robot Program/Folder 2/MoveL/Waypoint_1", ["movel(target, a=1.2, v=1.0)"]),
    "Relative waypoint first": (move("MoveL", '<Waypoint type="Relative" name="Waypoint_1"><motionParameters/>'
                                     f'{position(tag="fromPosition")}{position(tag="toPosition")}</Waypoint>'),
                                "Robot Program/Folder 2/MoveL/Waypoint_1",
                                ["movel(pose_add(get_target_tcp_pose(), pose_sub(p["]),
    "Wait for a condition": (f'<Wait type="Condition">{expression("x > 1")}</Wait>',
                             "Robot Program/Folder 2/Wait x > 1", ["while (not(x > 1)):", "  sync()"]),
    "Wait for an analog input": ('<Wait type="AnalogInput"><pin referencedName="analog_in[1]"/><analogComparison>1'
                                 "</analogComparison><analogValue>4.0</analogValue></Wait>",
                                 "Robot Program/Folder 2/Wait analog_in[1]>4.0",
                                 ["while (not(get_standard_analog_in(1) > 4.0)):"]),
    "Set an expression": (f'<Set type="Expression"><pin referencedName="digital_out[1]"/>{expression("x > 1")}</Set>',
                          "Robot Program/Folder 2/Set digital_out[1]=x > 1", ["set_standard_digital_out(1, x > 1)"]),
    "Set a register": ('<Set type="DigitalOutput"><pin referencedName="GP_bool_out[64]"/><digitalValue>1'
                       "</digitalValue></Set>", "Robot Program/Folder 2/Set GP_bool_out[64]=On",
                       ["write_output_boolean_register(64, True)"]),
    "Warning popup": ('<Popup type="Warning" message="careful &quot;now&quot;" haltProgram="false"/>',
                      'Robot Program/Folder 2/Popup: careful "now"',
                      ['popup("careful ?now?", "Warning", True, False, blocking=True)']),
    "Halting popup": ('<Popup type="Message" message="stop" haltProgram="true"/>',
                      "Robot Program/Folder 2/Popup: stop", ["halt"]),
    "Halt": ("<Halt/>", "Robot Program/Folder 2/Halt", ["halt"]),
    "Own waypoint time": (move("MoveJ", waypoint("timed", parameters='time="2.0"')),
                          "Robot Program/Folder 2/MoveJ/timed", ["movej(get_inverse_kin(p["]),
    "URCap node": ('<Contributed strategyClass="com.example.Gripper" strategyProgramNodeType="Gripper"/>',
                   "Robot Program/Folder 2/Gripper", None),
    "Circle move": (move("MoveC", waypoint("via")), "Robot Program/Folder 2/MoveC", None),
    "Unknown node": ("<Palletizing/>", "Robot Program/Folder 2/Palletizing", None),
}


@pytest.mark.parametrize("kind", UNSUPPORTED)
def test_a_node_without_a_step_is_refused_by_its_path_or_kept_as_polyscope_s_urscript(kind):
    xml, path, script = UNSUPPORTED[kind]
    program = tree(folder("Folder 2", SLEEP, xml, SLEEP))
    with pytest.raises(UnsupportedNodes) as refused:
        import_program(program)
    assert [problem.path for problem in refused.value.problems] == [path]
    assert f": 1 node without a ur3dq step: {path} (" in str(refused.value)
    if script is None:   # no URScript ur3dq can write: refused with --keep-script too, and the message says so
        assert "--keep-script cannot keep it" in str(refused.value)
        assert "import with --keep-script" not in str(refused.value)
        with pytest.raises(UnsupportedNodes, match="1 node without a ur3dq step"):
            import_program(program, keep_script=True)
        return
    assert str(refused.value).endswith(": import with --keep-script to keep them as URScript (not path-checked)")
    imported = import_program(program, keep_script=True)
    kept = [step for step in imported.steps if isinstance(step, KeptScript)]
    assert len(kept) == 1 and kept[0].origin == f"cell.urp: {path}"
    lines = kept[0].script.splitlines()
    for line in script:
        assert any(candidate.strip().startswith(line.strip()) and candidate.startswith(line[:len(line) -
                   len(line.lstrip())]) for candidate in lines), (line, kept[0].script)
    assert any("kept as URScript" in line and "not path-checked" in line for line in imported.warnings)


TOP_LEVEL = {
    "Thread": (f'<Thread name="Thread_1" runOnlyOnce="false"><children>{SLEEP}</children></Thread>', "Thread_1",
               ["thread Thread_1():", "  while (True):", "    sleep(0.1)", "threadId_Thread_1 = run Thread_1()"]),
    "Variables": (f"<InitVariablesNode><children>{UNSUPPORTED['Assignment'][0]}</children></InitVariablesNode>",
                  "Init Variables", ["global count=0"]),
    "BeforeStart": (f'<SpecialSequence type="BeforeStart"><children>{UNSUPPORTED["If"][0]}</children>'
                    "</SpecialSequence>", "BeforeStart/If digital_in[0]", ["if (get_standard_digital_in(0)):"]),
    "Unknown node": ("<Palletizing/>", "Palletizing", None),
}


@pytest.mark.parametrize("kind", TOP_LEVEL)
def test_a_top_level_node_without_a_step_is_refused_by_its_path_or_kept(kind):
    xml, path, script = TOP_LEVEL[kind]
    program = tree(SLEEP, top=xml)
    with pytest.raises(UnsupportedNodes) as refused:
        import_program(program)
    assert [problem.path for problem in refused.value.problems] == [path]
    assert ("import with --keep-script" in str(refused.value)) == (script is not None)
    if script is None:
        with pytest.raises(UnsupportedNodes, match=f"1 node without a ur3dq step: {path} "):
            import_program(program, keep_script=True)
        return
    imported = import_program(program, keep_script=True)
    assert [step.kind for step in imported.steps] == ["kept-script", "wait"]
    assert imported.steps[0].origin == f"cell.urp: {path}"
    lines = imported.steps[0].script.splitlines()
    assert all(line in lines for line in script), imported.steps[0].script


def test_every_node_without_a_step_is_named_at_once():
    top = f'<Thread name="Thread_1" runOnlyOnce="false"><children>{SLEEP}</children></Thread>'
    main = folder("Folder 2", UNSUPPORTED["If"][0], UNSUPPORTED["Halt"][0]) + UNSUPPORTED["Assignment"][0]
    with pytest.raises(UnsupportedNodes) as refused:
        import_program(tree(main, top=top))
    assert [problem.path for problem in refused.value.problems] == [
        "Thread_1", "Robot Program/Folder 2/If digital_in[0]", "Robot Program/Folder 2/Halt", "Robot Program/count:=0"]
    kept = import_program(tree(main, top=top), keep_script=True).steps
    assert kept[0].name == "Thread_1" and "threadId_Thread_1 = run Thread_1()" in kept[0].script


def test_a_program_without_a_main_program_or_a_model_is_refused():
    with pytest.raises(UrpFileError, match="it has no MainProgram node"):
        import_program(parse_urp_bytes(b'<URProgram name="x"><children/></URProgram>', "x.urp"), model_name="ur5")
    bare = b'<URProgram name="x"><children><MainProgram><children/></MainProgram></children></URProgram>'
    with pytest.raises(ValueError, match="its kinematics do not say which UR model it was saved on: pass --model"):
        import_program(parse_urp_bytes(bare, "x.urp"))
    with pytest.raises(ValueError, match="the program has no node ur3dq can import"):
        import_program(parse_urp_bytes(bare, "x.urp"), model_name="ur5")


def test_a_broken_reference_is_a_file_problem_of_ur3dq_s():
    from ur3dq.errors import StoreError

    with pytest.raises(UrpFileError, match=r"^cell.urp: broken reference '../../Set\[4\]/pin' at ") as refused:
        import_program(tree('<Set type="DigitalOutput"><pin reference="../../Set[4]/pin"/></Set>'))
    assert isinstance(refused.value, StoreError)   # exit code 3 on the command line


def test_a_relative_waypoint_moved_on_the_pendant_comes_back_fixed():
    from ur3dq.polyscope.urp_export import export_bytes
    from ur3dq.pose import Pose
    from ur3dq.program.plan import plan_program

    pick = Waypoint("pick", Pose.from_dual_quaternion("pick", UR5E.fk(HOME), "ur5e", joints=HOME))
    steps = [pick, RelativeWaypoint("above", "pick", (0, 0, -0.05, 0, 0, 0))]
    xml = __import__("gzip").decompress(export_bytes(plan_program(UR5E, steps), steps, "cell", UR5E)).decode()
    assert isinstance(import_program(parse_urp_bytes(xml.encode(), "cell.urp")).steps[1], RelativeWaypoint)
    angles = xml.split('<JointAngles angles="')[2].split('"')[0]
    moved = xml.replace(angles, ", ".join(str(float(v) + 0.01) for v in angles.split(",")))
    imported = import_program(parse_urp_bytes(moved.encode(), "cell.urp"))
    assert isinstance(imported.steps[1], Waypoint)
    assert any("step 'above': no longer where its base and offset put it" in line for line in imported.warnings)


@pytest.mark.parametrize("parameters, refusal", [
    ('cartesianSpeed="1e300"', "place (the waypoint: speed 1e+303 mm/s is outside the ur5e's range for a linear move"),
    ('cartesianAcceleration="1e-9"', "(the waypoint: acceleration 1e-06 mm/s² is outside the ur5e's range"),
])
def test_a_speed_or_acceleration_out_of_the_arms_range_is_refused_by_its_node(parameters, refusal):
    """What `poses set` refuses does not come in through a file (the plan would lower it to the limit)."""
    program = tree(move("MoveL", waypoint("place", HOME, (0.0,) * 6, parameters), speed="0.25", acceleration="1.2",
                        extra='positionType="CartesianPose"'))
    with pytest.raises(UnsupportedNodes) as refused:
        import_program(program)
    assert refusal in str(refused.value)
