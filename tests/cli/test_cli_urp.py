"""`ur3dq import-urp` and `ur3dq export-urp`: an imported program is a program like any other (list, check, dry
run, plot, export); bad and hostile files and programs without a counterpart fail with one line, the documented
exit code and the store unchanged, quickly."""
import gzip
import json
import shutil
import struct
import time
import tracemalloc
import zlib
from pathlib import Path

import pytest

from cli_support import assert_one_line_error

EXAMPLE = Path(__file__).parents[2] / "poses" / "example-poses.json"
TESTS = Path(__file__).parents[1]
UR5E = """<kinematics status="NOT_INITIALIZED" validChecksum="false">
    <deltaTheta value="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/><a value="0.0, -0.425, -0.3922, 0.0, 0.0, 0.0"/>
    <d value="0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996"/>
    <alpha value="1.570796327, 0.0, 0.0, 1.570796327, -1.570796327, 0.0"/>
    <jointChecksum value="-1, -1, -1, -1, -1, -1"/></kinematics>"""
HOME = "0.3, -1.3, 1.4, -1.7, -1.57, 0.4"
NEAR = "0.5, -1.2, 1.3, -1.7, -1.57, 0.4"


def program(main, top="", kinematics=UR5E):
    return (f'<URProgram name="cell" installation="default">{kinematics}<children>{top}'
            f'<MainProgram runOnlyOnce="true"><children>{main}</children></MainProgram></children></URProgram>')


def waypoint(name, q):
    return (f'<Waypoint type="Fixed" name="{name}"><motionParameters/><position><JointAngles angles="{q}"/>'
            f'<TCPOffset pose="0.0, 0.0, 0.1, 0.0, 0.0, 0.0"/></position></Waypoint>')


CELL = program(
    '<Move motionType="MoveJ" speed="1.0" acceleration="1.2" useActiveTCP="false"><children>'
    f'{waypoint("pick", HOME)}</children></Move>'
    '<Folder name="Grip"><children><Comment comment="close the gripper"/>'
    '<Set type="DigitalOutput"><pin referencedName="tool_out[0]"/><digitalValue>1</digitalValue></Set>'
    '<Wait type="Sleep"><waitTime>0.5</waitTime></Wait></children></Folder>'
    '<Move motionType="MoveL" speed="0.1" acceleration="1.2" useActiveTCP="false"><children>'
    f'{waypoint("place", NEAR)}</children></Move>')
IF_NODE = ('<Folder name="Folder 2"><children><If type="If"><expression><ExpressionIO>'
           '<pin referencedName="digital_in[0]"/></ExpressionIO></expression><children>'
           '<Wait type="Sleep"><waitTime>0.1</waitTime></Wait></children></If></children></Folder>')


def write(path, xml):
    path.write_bytes(gzip.compress(xml.encode(), mtime=0))
    return path


def test_an_imported_program_lists_checks_plots_and_exports_like_any_other(run_in_process, tmp_path):
    write(tmp_path / "cell.urp", CELL)
    result = run_in_process("import-urp", "cell.urp")
    assert result.returncode == 0, result.stderr
    assert "Imported 6 steps from cell.urp into poses.json." in result.stdout
    assert "cell.urp was saved on a UR5E with the same kinematics as the nominal UR5E model" in result.stderr
    listed = run_in_process("poses", "list")
    for row in ("pick", "Grip", "close the gripper", "Set tool_out[0]=On", "Wait 0.5", "place"):
        assert row in listed.stdout, listed.stdout
    assert run_in_process("check").returncode == 0
    dry = run_in_process("run-poses", "--dry-run")
    assert dry.returncode == 0 and "place" in dry.stdout, dry.stderr
    assert run_in_process("plot", "-o", "path.png").returncode == 0
    script = run_in_process("export-urscript")
    assert script.returncode == 0 and "set_tool_digital_out(0, True)" in script.stdout
    assert run_in_process("export-urp", "-o", "again.urp").returncode == 0
    assert run_in_process("--store", "again.json", "import-urp", "again.urp").returncode == 0
    assert (tmp_path / "again.json").read_text().count('"type"') == 6


def test_the_path_check_of_an_imported_program_finds_a_new_fixture_in_its_way(run_in_process, tmp_path):
    """Why most people import: is my old program safe with the new fixture? A box where the TCP goes at 'place'."""
    from ur3dq.kinematics import robot_model

    write(tmp_path / "cell.urp", CELL)
    assert run_in_process("import-urp", "cell.urp").returncode == 0
    assert run_in_process("check").returncode == 0
    tcp = robot_model("ur5e").with_tcp((0, 0, 0.1, 0, 0, 0)).fk([float(v) for v in NEAR.split(",")]).translation
    fixture = {"name": "new fixture", "min": [v - 0.03 for v in tcp], "max": [v + 0.03 for v in tcp]}
    tool = {"capsule": {"from": [0, 0, 0], "to": [0, 0, 0.1], "radius": 0.02}}   # the TCP offset's tool
    (tmp_path / "cell.json").write_text(json.dumps({"boxes": [fixture], "tool": tool}))
    for command in (("check",), ("run-poses", "--dry-run")):
        checked = run_in_process(*command, "--cell", "cell.json")
        assert checked.returncode == 4, (command, checked.stderr)
        assert "step 'place'" in checked.stdout + checked.stderr and '"new fixture"' in checked.stdout + checked.stderr


def test_export_urp_writes_the_same_bytes_for_the_same_program_and_never_the_store(run_in_process, tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    store = (tmp_path / "poses.json").read_bytes()
    (tmp_path / "again").mkdir()
    assert run_in_process("export-urp", "-o", "a.urp").returncode == 0
    assert run_in_process("export-urp", "-o", "b.urp", "--from", "demo-2", "--to", "demo-3").returncode == 0
    time.sleep(0.01)
    assert run_in_process("export-urp", "-o", "again/a.urp").returncode == 0
    assert (tmp_path / "a.urp").read_bytes() == (tmp_path / "again" / "a.urp").read_bytes()
    assert (tmp_path / "b.urp").read_bytes().count(b"<Waypoint ") == 2
    refused = run_in_process("export-urp", "-o", "poses.json", "--yes")
    assert_one_line_error(refused, 3, "pose store")
    assert (tmp_path / "poses.json").read_bytes() == store
    asked = run_in_process("export-urp", "-o", "a.urp")
    assert asked.returncode == 1   # exists: asks, and no answer is no


def test_export_urp_without_a_file_says_how_to_name_one(run_in_process, tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    for arguments in ((), ("-o", "-")):
        refused = run_in_process("export-urp", *arguments)
        assert_one_line_error(refused, 2, "export-urp writes a .urp file", "-o cell.urp")
    assert sorted(path.name for path in tmp_path.iterdir()) == ["poses.json"]


def test_import_into_a_program_needs_append_and_numbers_taken_names(run_in_process, tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    write(tmp_path / "cell.urp", CELL.replace('name="pick"', 'name="demo-1"'))
    before = (tmp_path / "poses.json").read_bytes()
    assert_one_line_error(run_in_process("import-urp", "cell.urp"), 3, "already holds 4 steps", "--append")
    assert (tmp_path / "poses.json").read_bytes() == before
    appended = run_in_process("import-urp", "cell.urp", "--append", "--json")
    assert appended.returncode == 0, appended.stderr
    assert "the name 'demo-1' is taken; imported as 'demo-5'" in appended.stderr
    listed = json.loads(run_in_process("poses", "list", "--json").stdout)["steps"]
    assert [step["name"] for step in listed][:5] == ["demo-1", "demo-2", "demo-3", "demo-4", "demo-5"]


def test_a_node_without_a_step_is_refused_by_its_path_or_kept_with_a_warning(run_in_process, tmp_path):
    write(tmp_path / "cell.urp", CELL.replace("</children></MainProgram>", IF_NODE + "</children></MainProgram>"))
    refused = run_in_process("import-urp", "cell.urp")
    assert_one_line_error(refused, 4, "cell.urp: 1 node without a ur3dq step: Robot Program/Folder 2/If digital_in[0]",
                          "--keep-script")
    assert not (tmp_path / "poses.json").exists()
    kept = run_in_process("import-urp", "cell.urp", "--keep-script")
    assert kept.returncode == 0 and "1 step kept as URScript run as it is, not path-checked" in kept.stderr
    assert "kept-script" in run_in_process("poses", "list").stdout
    dry = run_in_process("run-poses", "--dry-run")
    assert dry.returncode == 0 and "URScript kept from a PolyScope program runs as it is" in dry.stderr
    check = run_in_process("check")
    assert check.returncode == 0 and "its motions are not checked" in check.stderr
    assert "if (get_standard_digital_in(0)):" in run_in_process("export-urscript").stdout


def gzip_bomb(mib):
    """A valid gzip of `<URProgram>`, `mib` MiB of blanks and `</URProgram>` (1 GiB in 1 MB): one compressed MiB
    repeated (full flushes make the blocks independent), with the true CRC and length."""
    blanks = b" " * (1 << 20)
    deflate = zlib.compressobj(9, zlib.DEFLATED, -zlib.MAX_WBITS)
    head = deflate.compress(b"<URProgram>") + deflate.flush(zlib.Z_FULL_FLUSH)
    block = deflate.compress(blanks) + deflate.flush(zlib.Z_FULL_FLUSH)
    tail = deflate.compress(b"</URProgram>") + deflate.flush()
    crc = zlib.crc32(b"<URProgram>")
    for _ in range(mib):
        crc = zlib.crc32(blanks, crc)
    crc = zlib.crc32(b"</URProgram>", crc)
    size = (mib << 20) + len(b"<URProgram></URProgram>")
    header = b"\x1f\x8b\x08\x00\x00\x00\x00\x00\x02\xff"   # deflate, no name, no time stamp
    return header + head + block * mib + tail + struct.pack("<II", crc, size % 2**32)


BILLION_LAUGHS = ('<?xml version="1.0"?><!DOCTYPE lolz [<!ENTITY lol "lol">'
                  + "".join(f'<!ENTITY lol{n} "{("&lol" + str(n - 1) + ";") * 10 if n > 1 else "&lol;" * 10}">'
                            for n in range(1, 10))
                  + ']><URProgram name="x"><children>&lol9;</children></URProgram>')
HOSTILE = {
    "not gzip": (b"def p():\n  sleep(1)\nend\n", "not a PolyScope program"),
    "not XML": (gzip.compress(b"this is not XML", mtime=0), "its XML does not parse"),
    "truncated": (gzip.compress(CELL.encode(), mtime=0)[:-40], "truncated"),
    "billion laughs": (gzip.compress(BILLION_LAUGHS.encode(), mtime=0), "refused: the XML declares a DTD"),
    "deep nesting": (gzip.compress(b"<URProgram>" + b"<children>" * 100_000 + b"</children>" * 100_000
                                   + b"</URProgram>", mtime=0), "nested deeper than 200 levels"),
    "gzip bomb": (lambda: gzip_bomb(1024), "decompresses to more than 32 MB of XML"),
}
MEMORY_BOUND = 80 * 1024 * 1024   # the 32 MB of XML a program may expand to, with room for the parse


@pytest.mark.timeout(60)
@pytest.mark.parametrize("kind", [*HOSTILE, "100 MB", "missing"])
def test_bad_and_hostile_files_fail_with_one_line_exit_3_quickly_in_bounded_memory(run_in_process, tmp_path, kind):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    before = (tmp_path / "poses.json").read_bytes()
    path = tmp_path / "bad.urp"
    if kind == "100 MB":
        with open(path, "wb") as sparse:   # 100 MB long, nothing written to disk
            sparse.write(b"\x1f\x8b")
            sparse.truncate(100 * 1000 * 1000)
        message = "100 MB is larger than a PolyScope program can be"
    elif kind == "missing":
        message = "cannot be read"
    else:
        content, message = HOSTILE[kind]
        path.write_bytes(content() if callable(content) else content)
    started = time.monotonic()
    tracemalloc.start()
    try:
        result = run_in_process("import-urp", "bad.urp", "--append")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert time.monotonic() - started < 20
    assert peak < MEMORY_BOUND, f"{peak / 2**20:.0f} MiB allocated"
    assert_one_line_error(result, 3, "bad.urp", message)
    assert (tmp_path / "poses.json").read_bytes() == before


def test_a_program_saved_on_another_arm_says_so(run_in_process, tmp_path):
    write(tmp_path / "cell.urp", CELL)
    result = run_in_process("--model", "ur3e", "import-urp", "cell.urp")
    assert result.returncode == 0
    assert ("cell.urp was saved on a UR5E; the nominal UR3E model is a UR3E: ur3dq moves its TCP to the recorded "
            "poses by IK on the UR3E") in result.stderr


def test_the_comparison_is_with_the_connected_arm_when_there_is_one(run_cli, arm, tmp_path):
    ur3e = UR5E.replace("0.1625,", "0.15185,").replace("-0.425, -0.3922,", "-0.24355, -0.2132,").replace(
        "0.1333, 0.0997, 0.0996", "0.13105, 0.08535, 0.0921")
    write(tmp_path / "cell.urp", CELL.replace(UR5E, ur3e))
    result = run_cli("--host", arm.host, "import-urp", "cell.urp", "--json")
    assert result.returncode == 0, result.stderr
    assert "cell.urp was saved on a UR3E; the connected UR3 is a UR3" in result.stderr


def test_a_kept_script_runs_on_the_arm_with_the_rest_of_the_program(run_cli, arm, tmp_path):
    kept = ('<If type="If"><expression><ExpressionIO><pin referencedName="digital_in[0]"/></ExpressionIO>'
            '</expression><children><Set type="DigitalOutput"><pin referencedName="digital_out[5]"/>'
            '<digitalValue>1</digitalValue></Set></children></If><If type="Else"><children>'
            '<Set type="DigitalOutput"><pin referencedName="digital_out[6]"/><digitalValue>1</digitalValue></Set>'
            "</children></If>")
    ur3 = UR5E.replace("0.1625,", "0.1519,").replace("-0.425, -0.3922,", "-0.24365, -0.21325,").replace(
        "0.1333, 0.0997, 0.0996", "0.11235, 0.08535, 0.0819")
    write(tmp_path / "cell.urp", program(kept + '<Move motionType="MoveJ" speed="1.0" acceleration="1.2" '
                                         f'useActiveTCP="false"><children>{waypoint("pick", HOME)}</children></Move>',
                                         kinematics=ur3))
    assert run_cli("import-urp", "cell.urp", "--keep-script").returncode == 0
    ran = run_cli("--host", arm.host, "run-poses", "--yes", "--tcp", "recorded")   # the .urp's own TCP
    assert ran.returncode == 0, ran.stderr
    assert "runs as it is: its motions are not checked" in " ".join(ran.stderr.split())   # wrapped at 80 columns
    import rtde_receive

    outputs = int(rtde_receive.RTDEReceiveInterface(arm.host).getActualDigitalOutputBits())
    assert (outputs >> 6) & 1 and not (outputs >> 5) & 1   # digital_in[0] is off: the Else branch ran


def test_export_with_the_arm_s_calibration_says_when_the_poses_were_taught_on_another_arm(run_cli, arm, tmp_path):
    data = json.loads(EXAMPLE.read_text())
    data["poses"][1]["robot_model"] = "ur5"
    (tmp_path / "poses.json").write_text(json.dumps(data))
    exported = run_cli("--host", arm.host, "export-urp", "-o", "cell.urp", "--calibration", "robot")
    assert exported.returncode == 0, exported.stderr
    assert ("Warning: poses of the program were taught on a UR5, not on the connected UR3: the file carries the "
            "connected arm's calibration") in exported.stderr
    same = run_cli("--host", arm.host, "export-urp", "-o", "part.urp", "--calibration", "robot", "--to", "demo-1")
    assert same.returncode == 0 and "taught" not in same.stderr, same.stderr


def test_the_serial_numbers_of_the_poses_are_compared_with_the_connected_arm_s():
    import dataclasses

    from ur3dq.cli.export_urp import taught_elsewhere
    from ur3dq.store import PoseStore

    steps = PoseStore(EXAMPLE).load_program()
    mine = [dataclasses.replace(step, pose=dataclasses.replace(step.pose, robot_serial="20203500001"))
            for step in steps]
    assert taught_elsewhere(mine, "ur3", "20203500001") is None
    assert taught_elsewhere(mine, "ur3", None) is None   # a CB3 does not tell its serial number
    assert taught_elsewhere(mine[:1] + steps[1:], "ur3", "20203500002") == (
        "poses of the program were taught on the arm with serial number 20203500001, not on the connected UR3 "
        "(serial number 20203500002): the file carries the connected arm's calibration and its IK joints")
