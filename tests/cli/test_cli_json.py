"""Every command's --json output is one object with "schema": 1 and matches its schema in docs/json.md; the walk
over click's registry makes a new command fail here until its output is documented and run."""
import json
import shutil
from pathlib import Path

import click
import jsonschema
import pytest

from ur3dq.cli import cli

DOC = Path(__file__).parents[2] / "docs" / "json.md"
EXAMPLE = Path(__file__).parents[2] / "poses" / "example-poses.json"
CELL = {"floor": {"z": -0.2}, "margin": 0.01}


def documented_schemas():
    """{section title: JSON Schema} of docs/json.md, each with the shared $defs."""
    schemas, title, block = {}, None, None
    for line in DOC.read_text(encoding="utf-8").splitlines():
        if block is not None:
            if line.startswith("```"):
                schemas[title], block = json.loads("\n".join(block)), None
            else:
                block.append(line)
        elif line.startswith("#"):
            title = line.lstrip("#").strip()
        elif line.startswith("```json"):
            block = []
    defs = schemas.pop("Shared definitions")["$defs"]
    return {title: {**schema, "$defs": defs} for title, schema in schemas.items()}


SCHEMAS = documented_schemas()


def section_of(path):
    """The docs/json.md section documenting the command `path` (a tuple of names): its title names it."""
    wanted = "`ur3dq " + " ".join(path) + "`"
    titles = [title for title in SCHEMAS if wanted in title]
    assert len(titles) == 1, f"{wanted} is documented in {len(titles)} sections of docs/json.md"
    return titles[0]


def leaf_paths(group=cli, path=()):
    for name, command in sorted(group.commands.items()):
        if isinstance(command, click.Group):
            yield from leaf_paths(command, (*path, name))
        else:
            yield (*path, name)


checked = set()


def validate(path, result):
    """Check that `result` succeeded and printed one JSON object valid against its command's schema."""
    assert result.returncode == 0, (path, result.stderr)
    document = json.loads(result.stdout)
    assert document["schema"] == 1
    jsonschema.validate(document, SCHEMAS[section_of(path)])
    checked.add(tuple(path))
    return document


@pytest.fixture
def program(tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    (tmp_path / "cell.json").write_text(json.dumps(CELL))
    return tmp_path


def test_the_sections_cover_the_commands():
    for path in leaf_paths():
        section_of(path)


def test_offline_commands_match_their_schemas(run_in_process, program):
    run = run_in_process
    validate(("fk",), run("fk", "0", "-90deg", "0", "-90deg", "0", "0", "--json"))
    validate(("ik",), run("ik", "0.3", "0.1", "0.2", "0", "180deg", "0", "--near", *["0.1"] * 6, "--json"))
    validate(("poses", "list"), run("poses", "list", "--json"))
    validate(("run-poses",), run("run-poses", "--dry-run", "--json", "--cell", "cell.json"))
    validate(("check",), run("check", "--json", "--cell", "cell.json"))
    validate(("export-urscript",), run("export-urscript", "--json"))
    validate(("export-urscript",), run("export-urscript", "-o", "x.script", "--json"))
    validate(("export-urp",), run("export-urp", "-o", "x.urp", "--json"))
    validate(("import-urp",), run("--store", "imported.json", "import-urp", "x.urp", "--json"))
    validate(("poses", "export"), run("poses", "export", "-", "--json"))
    validate(("poses", "export"), run("poses", "export", "t.txt", "--json"))
    validate(("poses", "import"), run("poses", "import", "t.txt", "--json", "--prefix", "t"))
    validate(("poses", "rename"), run("poses", "rename", "t-1", "again", "--json"))
    validate(("poses", "rm"), run("poses", "rm", "again", "--yes", "--json"))
    validate(("poses", "show"), run("poses", "show", "demo-1", "--json"))
    validate(("poses", "set"), run("poses", "set", "demo-2", "--move", "linear", "--speed", "100mm/s", "--json"))
    validate(("poses", "offset"), run("poses", "offset", "above", "--from", "demo-2", "--z", "-50mm", "--before",
                                      "demo-2", "--json"))
    validate(("poses", "move"), run("poses", "move", "above", "--after", "demo-1", "--json"))
    validate(("poses", "copy"), run("poses", "copy", "demo-1", "demo-1b", "--json"))
    for args in (("tool-out", "0", "on"), ("digital-out", "1", "off"), ("configurable-out", "2", "on"),
                 ("analog-out", "0", "0.5"), ("wait", "500ms"), ("wait-input", "3", "on"), ("message", "hi")):
        validate(("poses", "add-step", args[0]), run("poses", "add-step", "--after", "demo-2", *args, "--json"))
    validate(("poses", "list"), run("poses", "list", "--json"))   # now a cell program: steps
    validate(("poses", "show"), run("poses", "show", "above", "--json"))
    validate(("run-poses",), run("run-poses", "--dry-run", "--json"))
    validate(("plot",), run("plot", "-o", "p.png", "--json"))


def test_robot_commands_match_their_schemas(run_cli, arm, program):
    host = ("--host", arm.host)
    validate(("status",), run_cli(*host, "status", "--json"))
    validate(("robot", "stop"), run_cli(*host, "robot", "stop", "--json"))
    validate(("record-pose",), run_cli(*host, "record-pose", "--name", "here", "--yes", "--json"))
    validate(("poses", "retouch"), run_cli(*host, "poses", "retouch", "here", "--yes", "--json"))
    validate(("run-poses",), run_cli(*host, "run-poses", "--from", "demo-1", "--to", "demo-1", "--yes", "--json"))
    validate(("move-to",), run_cli(*host, "move-to", "here", "--yes", "--json"))
    validate(("jog",), run_cli(*host, "jog", "--json", input="2+rq"))   # without a terminal: keys from stdin


def test_simulator_commands_match_their_schemas(run_cli, tmp_path):
    import time

    from sim_ursim.control_channel import send_request

    validate(("sim", "status"), run_cli("sim", "status", "--json"))
    started = validate(("sim", "start"), run_cli("sim", "start", "--json"))
    try:
        validate(("sim", "status"), run_cli("sim", "status", "--json"))
        assert send_request(started["host"], "protective-stop").get("ok")
        time.sleep(5.2)   # a controller refuses the unlock within 5 s of the stop
        validate(("robot", "unlock"), run_cli("robot", "unlock", "--json"))
        validate(("robot", "power-off"), run_cli("robot", "power-off", "--json"))
        validate(("robot", "power-on"), run_cli("robot", "power-on", "--json"))
        validate(("robot", "brake-release"), run_cli("robot", "brake-release", "--json"))
        validate(("robot", "freedrive"), run_cli("robot", "freedrive", "on", "--json", input="\n"))   # Enter ends it
        validate(("robot", "freedrive"), run_cli("robot", "freedrive", "off", "--json"))
    finally:
        stopped = validate(("sim", "stop"), run_cli("sim", "stop", "--json"))
    assert stopped["stopped"]["host"] == started["host"]


def test_demo_matches_its_schema(run_cli):
    validate(("demo",), run_cli("demo", "--json", timeout=180))


def test_serve_matches_its_schema(tmp_path):
    import signal
    import subprocess
    import sys
    from types import SimpleNamespace

    command = [sys.executable, "-m", "ur3dq", "--store", str(tmp_path / "p.json"), "serve", "--port", "0", "--json"]
    with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                          env={"UR3DQ_STATE_DIR": str(tmp_path)}) as server:
        try:
            lines = [server.stdout.readline()]      # the object, indented, up to its closing brace
            while lines[-1] and not lines[-1].startswith("}"):
                lines.append(server.stdout.readline())
            text, running = "".join(lines), server.poll() is None
        finally:
            server.send_signal(signal.SIGTERM)
    assert running
    document = validate(("serve",), SimpleNamespace(returncode=0, stdout=text, stderr=""))
    assert document["url"] == f"http://127.0.0.1:{document['port']}/" and document["robot"] is None


def test_every_command_was_run_with_json():
    """Runs last in this file: every command of click's registry printed a validated document above."""
    assert set(leaf_paths()) <= checked, sorted(set(leaf_paths()) - checked)
