"""PolyScope program trees -> URScript, node kind by node kind (sim_ursim.polyscope.translation and moves).

Each generated program is also compiled by the simulator's own URScript compiler: what the translation writes is
what the interpreter runs.
"""
import gzip

import pytest

from polyscope_format.urp_file import UrpFormatError, parse_urp_bytes
from sim_ursim.polyscope.errors import UrpError
from sim_ursim.polyscope.translation import program_def_name, program_urscript
from sim_ursim.urscript.builtins import BUILTINS
from sim_ursim.urscript.interpreter import compile_program
from sim_ursim.urscript.parser import parse
from urp_samples import E_SERIES_EXTERNAL_CONTROL, E_SERIES_WAIT_PROGRAM, expression, program_xml

Q1 = "-1.6, -1.7, -2.2, -0.8, 1.6, -0.03"
Q1_LIST = "[-1.6, -1.7, -2.2, -0.8, 1.6, -0.03]"


def translated(xml: str, contributed=None) -> str:
    """The URScript for `xml`, after checking that the simulator compiles it."""
    script = program_urscript(parse_urp_bytes(gzip.compress(xml.encode())), contributed)
    compile_program(parse(script), BUILTINS)
    return script


def statements(script: str) -> list[str]:
    """The program's lines without PolyScope's `$` markers, stripped."""
    return [line.strip() for line in script.splitlines() if line.strip() and not line.strip().startswith("$")]


def main_statements(main: str, **options) -> list[str]:
    """The statements a MainProgram of `main` nodes becomes, between `def` and `end`."""
    return statements(translated(program_xml(main, **options)))[1:-1]


def assignment(name: str, value: str) -> str:
    return (f'<Assignment valueSource="Expression"><variable name="{name}" prefersPersistentValue="false">'
            f"<initializeExpression/></variable>{expression(value)}</Assignment>")


X_IS_1 = assignment("x", "1")


def waypoint(name: str = "Waypoint_1", q: str = Q1, tcp: str = "0.0, 0.0, 0.12, 0.0, 0.0, 0.0",
             parameters: str = "<motionParameters/>") -> str:
    return (f'<Waypoint type="Fixed" name="{name}" kinematicsFlags="4">{parameters}<position>'
            f'<JointAngles angles="{q}"/><TCPOffset pose="{tcp}"/></position></Waypoint>')


# ------------------------------------------------------------------------------------------ real programs
def test_urcl_wait_program_loops_its_wait_forever():
    assert translated(E_SERIES_WAIT_PROGRAM) == (
        'def wait_program():\n  while (True):\n    $ 1 "Robot Program"\n    $ 2 "Wait: 0.01"\n    sleep(0.01)\n'
        "  end\nend\n")


def test_urcl_external_control_program_inserts_the_urcap_script_once():
    calls = []

    def urcap(tree, node):
        calls.append(node.get("strategyClass"))
        return "textmsg(\"from the remote PC\")\n"

    script = translated(E_SERIES_EXTERNAL_CONTROL, urcap)
    assert statements(script) == ["def external_control():", 'textmsg("from the remote PC")', "end"]
    assert calls == ["com.fzi.externalcontrol.ExternalControlNode"]


def test_a_urcap_node_is_refused_without_a_urcap_to_write_it():
    with pytest.raises(UrpError, match=r"URProgram/MainProgram/Contributed: URCap node 'External Control'"):
        translated(E_SERIES_EXTERNAL_CONTROL)


def test_program_names_become_def_names_as_polyscope_writes_them():
    assert program_def_name("5exIF") == "P5exIF"
    assert program_def_name("pick and place-2") == "pick_and_place_2"
    assert program_def_name("wait_program") == "wait_program"


# ------------------------------------------------------------------------------------------ nodes
def test_set_digital_analog_and_register_outputs():
    main = ('<Set type="DigitalOutput"><pin referencedName="digital_out[2]"/><digitalValue>1</digitalValue></Set>'
            '<Set type="DigitalOutput"><pin reference="../../Set/pin"/><digitalValue>0</digitalValue></Set>'
            '<Set type="DigitalOutput"><pin referencedName="config_out[1]"/><digitalValue>1</digitalValue></Set>'
            '<Set type="DigitalOutput"><pin referencedName="tool_out[0]"/><digitalValue>0</digitalValue></Set>'
            '<Set type="AnalogOutput"><pin referencedName="analog_out[1]"/><analogValue>0.25</analogValue></Set>'
            f'<Set type="Expression"><pin referencedName="GP_int_out[3]"/>{expression("2+3")}</Set>')
    assert main_statements(main) == [
        "set_standard_digital_out(2, True)", "set_standard_digital_out(2, False)",
        "set_configurable_digital_out(1, True)", "set_tool_digital_out(0, False)", "set_standard_analog_out(1, 0.25)",
        "write_output_integer_register(3, 2+3)"]


def test_wait_sleep_input_analog_and_expression():
    main = ('<Wait type="Sleep"><waitTime>0.5</waitTime></Wait>'
            '<Wait type="DigitalInput"><pin referencedName="digital_in[2]"/><digitalValue>1</digitalValue></Wait>'
            '<Wait type="AnalogInput"><pin referencedName="analog_in[1]"/><analogComparison>1</analogComparison>'
            '<analogValue>4.0</analogValue></Wait>'
            f'{X_IS_1}<Wait type="Condition">{expression("x > 2")}</Wait>')
    assert main_statements(main) == [
        "sleep(0.5)",
        "while (not(get_standard_digital_in(2) == True)):", "sync()", "end",
        "while (not(get_standard_analog_in(1) > 4.0)):", "sync()", "end",
        "global x=1", "while (not(x > 2)):", "sync()", "end"]


def test_loops_forever_counted_and_while():
    body = '<children><Wait type="Sleep"><waitTime>0.1</waitTime></Wait></children>'
    main = (f'{X_IS_1}<Loop type="Counting" count="3">{body}</Loop>'
            f'<Loop type="While" checkContinuously="false">{expression("x < 5")}{body}</Loop>'
            f'<Loop type="Forever">{body}</Loop>')
    assert main_statements(main) == [
        "global x=1", "Loop_1 = 0", "while (Loop_1 < 3):", "sleep(0.1)", "Loop_1 = Loop_1 + 1", "end",
        "while (x < 5):", "sleep(0.1)", "end",
        "while (True):", "sleep(0.1)", "end"]


@pytest.mark.parametrize("chain", [
    # 5.x: ElseIf / Else follow the If as siblings, all three <If type=...>
    '<If type="If" checkContinuously="false">{c1}<children>{a}</children></If>'
    '<If type="ElseIf" checkContinuously="false">{c2}<children>{b}</children></If>'
    '<If type="Else" checkContinuously="false"><expression/><children>{c}</children></If>',
    # ElseIf / Else as their own tags inside the If's children
    '<If>{c1}<children>{a}<ElseIf>{c2}<children>{b}</children></ElseIf><Else><children>{c}</children></Else>'
    '</children></If>',
])
def test_if_elseif_else_in_both_spellings(chain):
    def sleep(t):
        return f'<Wait type="Sleep"><waitTime>{t}</waitTime></Wait>'

    main = X_IS_1 + chain.format(c1=expression("x == True"), c2=expression("x == 2"), a=sleep(1), b=sleep(2),
                                 c=sleep(3))
    assert main_statements(main) == ["global x=1", "if (x == True):", "sleep(1.0)", "elif (x == 2):", "sleep(2.0)",
                                     "else:", "sleep(3.0)", "end"]


def test_a_continuously_checked_if_is_refused_with_its_place():
    main = (f'<Folder name="f"><children><If type="If" checkContinuously="true">{expression("x")}</If>'
            "</children></Folder>")
    with pytest.raises(UrpError, match=r"MainProgram/Folder/If: a continuously checked If is not supported"):
        main_statements(main)


def test_script_line_file_assignment_comment_folder_halt():
    main = (f'<Script type="Line">{expression("textmsg(1)")}</Script>'
            '<Script type="File"><cachedContents>def twice(x):\n\treturn 2 * x\nend\n</cachedContents>'
            '<file>/ursim/programs/twice.script</file></Script>'
            f'<Assignment valueSource="Expression"><variable name="n" prefersPersistentValue="false">'
            f'<initializeExpression/></variable>{expression("twice(3)")}</Assignment>'
            '<Comment comment="the &quot;end&quot;"/>'
            '<Folder name="Grip"><children><Halt/></children></Folder>')
    assert main_statements(main) == ["textmsg(1)", "def twice(x):", "return 2 * x", "end", "global n=twice(3)",
                                     "# the 'end'", "halt"]


def test_popup_kinds_and_halting_popups():
    main = ('<Popup type="Warning" haltProgram="false" message="Check the &quot;gripper&quot;"/>'
            '<Popup type="Error" haltProgram="true" message="Stop"/>')
    assert main_statements(main) == ["popup(\"Check the 'gripper'\", \"Warning\", True, False, blocking=True)",
                                     'popup("Stop", "Error", False, True, blocking=True)', "halt"]


def test_before_start_init_variables_threads_and_sub_programs():
    top = ('<InitVariablesNode><children>' + assignment("count", "0") + "</children></InitVariablesNode>"
           '<SpecialSequence type="BeforeStart"><children>' + assignment("ready", "True")
           + "</children></SpecialSequence>"
           '<Thread name="Watch"><children><Wait type="Sleep"><waitTime>1</waitTime></Wait></children></Thread>')
    main = ('<CallSubProgram><subprogram name="Grip" keepHidden="false" keepSynchronizedWithDisk="false"><children>'
            + assignment("count", "count + 1") + "</children></subprogram></CallSubProgram>"
            '<CallSubProgram><subprogram reference="../../CallSubProgram/subprogram"/></CallSubProgram>')
    top_after = '<SubProgram reference="../MainProgram/children/CallSubProgram/subprogram"/>'
    xml = program_xml(main, run_once=False, top=top).replace("</MainProgram>", "</MainProgram>" + top_after)
    assert statements(translated(xml)) == [
        "def cell():",
        "def Grip():", "global count=count + 1", "end",
        "global count=0", "global ready=True",
        "thread Watch():", "while (True):", "sleep(1.0)", "sync()", "end", "end", "threadId_Watch = run Watch()",
        "while (True):", "Grip()", "Grip()", "end",
        "end"]


def test_fixed_waypoints_move_to_joints_or_to_their_tcp_pose():
    parameters = '<motionParameters jointSpeed="0.5" blendRadius="0.01"/>'
    moves = (f'<Move motionType="MoveJ" speed="1.0" acceleration="1.4" useActiveTCP="true"><children>'
             f"{waypoint(parameters=parameters)}"
             "</children></Move>"
             f'<Move motionType="MoveL" speed="0.25" acceleration="1.2" useActiveTCP="false"><children>'
             f"{waypoint('Waypoint_2')}</children></Move>"
             f'<Move motionType="MoveP" speed="0.1" acceleration="0.5" blendRadius="0.02" useActiveTCP="true">'
             f"<children>{waypoint('Waypoint_3')}</children></Move>")
    pose = f"get_forward_kin({Q1_LIST}, p[0.0, 0.0, 0.12, 0.0, 0.0, 0.0])"
    assert main_statements(moves) == [
        f"movej({Q1_LIST}, a=1.4, v=0.5, r=0.01)",
        "set_tcp(p[0.0, 0.0, 0.12, 0.0, 0.0, 0.0])", f"movel({pose}, a=1.2, v=0.25)",
        f"movep({pose}, a=0.5, v=0.1, r=0.02)"]


def test_3x_positions_relative_and_variable_waypoints():
    position_3x = '<position joints="0.1, -1.5, 1.2, -1.3, -1.6, 0.0" pose="0.3, -0.2, 0.4, 3.14, 0.0, 0.0"/>'
    relative = ('<Waypoint type="Relative" name="Up"><motionParameters/>'
                '<fromPosition pose="0.3, -0.2, 0.4, 3.14, 0.0, 0.0"/>'
                '<toPosition pose="0.3, -0.2, 0.5, 3.14, 0.0, 0.0"/>'
                "</Waypoint>")
    main = (f'<Move motionType="MoveL" speed="0.25" acceleration="1.2"><children>'
            f'<Waypoint type="Fixed" name="W">{position_3x}</Waypoint>{relative}'
            '<Waypoint type="Variable" name="V"><variable name="target"/></Waypoint>'
            '<Set type="DigitalOutput"><pin referencedName="digital_out[0]"/><digitalValue>1</digitalValue></Set>'
            "</children></Move>")
    xml = program_xml(main).replace("<MainProgram", '<SpecialSequence type="BeforeStart"><children>'
                                    '<Assignment valueSource="Expression"><variable name="target"/>'
                                    + expression("p[0.3, -0.2, 0.3, 3.14, 0, 0]")
                                    + "</Assignment></children></SpecialSequence><MainProgram")
    assert statements(translated(xml))[2:-1] == [
        "movel(p[0.3, -0.2, 0.4, 3.14, 0.0, 0.0], a=1.2, v=0.25)",
        "movel(pose_add(get_target_tcp_pose(), pose_sub(p[0.3, -0.2, 0.5, 3.14, 0.0, 0.0], "
        "p[0.3, -0.2, 0.4, 3.14, 0.0, 0.0])), a=1.2, v=0.25)",
        "movel(target, a=1.2, v=0.25)",
        "set_standard_digital_out(0, True)"]


@pytest.mark.parametrize("main, message", [
    ("<Pallet/>", r"MainProgram/Pallet: node <Pallet> is not supported by sim_ursim"),
    ('<Move motionType="MoveC"><children/></Move>', r"motion type 'MoveC' is not supported"),
    ('<Set type="DigitalOutput"><pin referencedName="gripper"/><digitalValue>1</digitalValue></Set>',
     r"MainProgram/Set: I/O pin 'gripper' is neither one of PolyScope's default pin names nor named"),
    ('<Set type="DigitalOutput"><pin referencedName="digital_in[1]"/><digitalValue>1</digitalValue></Set>',
     r"is an input: it cannot be set"),
    ('<Assignment valueSource="Operator"><variable name="x"/></Assignment>', r"operator input"),
    ('<Script type="Line"><expression/></Script>', r"MainProgram/Script: the node's expression is empty"),
    ('<Wait type="Sleep"><waitTime>soon</waitTime></Wait>', r"waitTime 'soon' is not a number"),
    ('<Move motionType="MoveJ"><children><Waypoint type="Fixed"><position><JointAngles angles="1, 2"/></position>'
     "</Waypoint></children></Move>", r"MainProgram/Move/Waypoint/position: '1, 2' is not 6 numbers"),
    ('<Else><children/></Else>', r"Else without its If"),
    ('<Contributed strategyClass="com.example.Gripper" strategyProgramNodeType="Grip"/>', r"URCap node 'Grip'"),
])
def test_what_the_simulator_cannot_run_is_refused_naming_the_node(main, message):
    with pytest.raises(UrpError, match=message):
        main_statements(main)


def test_a_broken_reference_is_the_file_s_problem_and_says_where():
    with pytest.raises(UrpFormatError, match=r"broken reference '../../Nowhere/pin' at URProgram/MainProgram/Set/pin"):
        main_statements('<Set type="DigitalOutput"><pin reference="../../Nowhere/pin"/></Set>')


def test_a_polyscope_3_program_with_pendant_symbols_variable_waypoints_and_a_thread():
    """The shape of UR's RTDE example program rtde_control_loop.urp (saved by PolyScope 3.6, plain XML): an If whose
    expression mixes typed characters with pendant symbols, tokens and a referenced variable; a Variable waypoint
    referring to that variable; a thread looping a Forever loop."""
    before_start = ('<SpecialSequence type="BeforeStart"><children>' + assignment("setp", "p[0,0,0,0,0,0]")
                    + "</children></SpecialSequence>")
    condition = ('<expression>' + expression("read_input_integer_register(0)≟1")[12:-13]
                 + '<ExpressionToken token=" and "/><ExpressionVariable><ProgramVariable reference="../../../../../'
                 '../SpecialSequence/children/Assignment/variable"/></ExpressionVariable>'
                 + expression("≠p[0, 0, 0, 0, 0, 0]")[12:-13] + "</expression>")
    main = (f'<If type="If" checkContinuously="false">{condition}<children>'
            '<Move motionType="MoveL" speed="0.08" acceleration="1.2" useActiveTCP="false"><children>'
            '<Waypoint type="Variable" name="Waypoint" kinematicsFlags="-1"><motionParameters/>'
            '<variable reference="../../../../../../../../SpecialSequence/children/Assignment/variable"/>'
            "</Waypoint></children></Move></children></If>")
    thread = ('<Thread name="Thread_1" runOnlyOnce="false"><children><Loop type="Forever"><children>'
              + assignment("setp", "p[0.1,0,0,0,0,0]") + "</children></Loop></children></Thread>"
              '<Thread name="Once" runOnlyOnce="true"><children><Halt/></children></Thread>')
    xml = program_xml(main, run_once=False, top=before_start).replace("</MainProgram>", "</MainProgram>" + thread)
    assert statements(translated(xml)) == [
        "def cell():", "global setp=p[0,0,0,0,0,0]",
        "thread Thread_1():", "while (True):", "while (True):", "global setp=p[0.1,0,0,0,0,0]", "end", "sync()",
        "end", "end", "threadId_Thread_1 = run Thread_1()",
        "thread Once():", "halt", "end", "threadId_Once = run Once()",
        "while (True):", "if (read_input_integer_register(0)==1 and setp!=p[0, 0, 0, 0, 0, 0]):",
        "movel(setp, a=1.2, v=0.08)", "end", "end", "end"]
