"""Every number typed on the command line goes through ur3dq.units: --deg and --mm are honoured before or after the
command, units may be typed (`250mm/s`, `60deg/s`, `-50mm`, `5deg`), and values out of the model's range for the
move type are refused when set. The walk over click's registry finds every option that takes an angle, an angular
speed or acceleration, or a rotation, so a new one cannot escape the units layer."""
import json
import math
import shutil
from pathlib import Path

import click
import pytest

from cli_support import assert_one_line_error
from ur3dq.cli import cli
from ur3dq.cli.options import Quantity, Typed, TypedValue
from ur3dq.store import PoseStore
from ur3dq.units import ANGULAR_SPEED, LENGTH

EXAMPLE = Path(__file__).parents[2] / "poses" / "example-poses.json"

# Options that take a plain number on purpose: a fraction, a sine, or a unit in their very name.
DIMENSIONLESS = {("run-poses", "speed_scale"), ("check", "wrist"), ("check", "elbow"), ("demo", "tolerance_mm"),
                 ("demo", "tolerance_deg")}


def leaf_commands(group=cli, path=()):
    """(path of names, click.Command) of every command that runs something (not a group)."""
    for name, command in sorted(group.commands.items()):
        if isinstance(command, click.Group):
            yield (*path, name), command      # a group with a callback of its own (add-step) takes options too
            yield from leaf_commands(command, (*path, name))
        else:
            yield (*path, name), command


def member_types(param):
    """The click types a parameter converts with (a tuple type's members, or the type itself)."""
    return list(param.type.types) if isinstance(param.type, click.Tuple) else [param.type]


def angular_params():
    """(command path, command, parameter) of every parameter that takes an angle, an angular speed or
    acceleration, or a rotation."""
    for path, command in leaf_commands():
        for param in command.params:
            kinds = [kind for t in member_types(param) for kind in
                     ([t.kind] if isinstance(t, Quantity) else list(t.kinds) if isinstance(t, Typed) else [])]
            if any(kind.angular for kind in kinds):
                yield path, command, param


def test_no_physical_quantity_is_read_as_a_bare_float():
    bare = [(" ".join(path), param.name) for path, command in leaf_commands() for param in command.params
            if any(t is click.FLOAT for t in member_types(param)) and (path[-1], param.name) not in DIMENSIONLESS]
    assert not bare, f"declare these with options.Quantity or options.Typed: {bare}"


def test_every_command_takes_deg_mm_and_json_after_its_name():
    missing = [" ".join(path) for path, command in leaf_commands() if not isinstance(command, click.Group)
               and not {"--deg", "--mm", "--json"} <= {opt for p in command.params for opt in p.opts}]
    assert not missing


def filler(param):
    """Arguments a parse needs besides the one under test."""
    if isinstance(param, click.Argument):
        if param.nargs == -1:
            return []
        if isinstance(param.type, click.Choice):
            return [param.type.choices[0]]
        return ["1"] * param.nargs
    if param.required:
        return [param.opts[0], "x"]
    return []


def parse(monkeypatch, path, command, param, words, deg_before=False, deg_after=False):
    """The value `command` receives for `param` when `words` are typed for it (nothing runs)."""
    captured = {}
    monkeypatch.setattr(command, "callback", lambda *args, **kwargs: captured.update(kwargs))
    others = [word for p in command.params if p is not param for word in filler(p)]
    typed = words if isinstance(param, click.Argument) else [param.opts[0], *words]
    separator = ["--"] if words[0].startswith("-") and isinstance(param, click.Argument) else []
    args = [*(["--deg"] if deg_before else []), *path, *others, *separator, *typed]
    if deg_after:   # the last word on the line, or just before `--`
        args.insert(args.index("--") if separator else len(args), "--deg")
    if isinstance(command, click.Group):   # a group runs only with a subcommand: give it its first one
        args.append(sorted(command.commands)[0])
        args += [word for p in command.commands[sorted(command.commands)[0]].params for word in filler(p)]
    cli.main(args=args, prog_name="ur3dq", standalone_mode=False)
    return captured[param.name]


def si_values(value, param):
    """The angles a captured value carries, in SI (TypedValue: read as the angular kind it may be)."""
    values = value if isinstance(value, tuple) else (value,)
    out = []
    members = member_types(param) if isinstance(param.type, click.Tuple) else member_types(param) * len(values)
    for item, kind in zip(values, members, strict=True):
        if isinstance(item, TypedValue):
            item = item.si(next(k for k in kind.kinds if k.angular))
        if isinstance(kind, Quantity) and not kind.kind.angular:
            continue   # a length beside the angles (X Y Z of a pose vector)
        out.append(item)
    return out


def explicit(member):
    """60 degrees (or °/s, °/s²) of the member's angular kind, with its unit; a plain 60 for a length member."""
    kinds = [member.kind] if isinstance(member, Quantity) else list(member.kinds)
    angular = next((kind for kind in kinds if kind.angular), None)
    return "60" if angular is None else "60" + {"rad": "deg", "rad/s": "deg/s", "rad/s²": "deg/s^2"}[angular.si]


@pytest.mark.parametrize("path, command, param", list(angular_params()),
                         ids=[f"{' '.join(p)} {q.name}" for p, _, q in angular_params()])
def test_every_angular_value_follows_deg_before_or_after_the_command(monkeypatch, tmp_path, path, command, param):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "1").write_text("")   # a FILE argument the parse needs
    members = member_types(param)
    count = param.nargs if param.nargs > 0 else 6
    words = ["3"] * count   # bare: within every option's bare range (an offset's turn: up to π rad)
    for options, expected in (({}, 3.0), ({"deg_before": True}, math.radians(3)),
                              ({"deg_after": True}, math.radians(3))):
        values = si_values(parse(monkeypatch, path, command, param, words, **options), param)
        assert values and values == pytest.approx([expected] * len(values)), options
    typed = [explicit(member) for member in members] * (count // len(members))
    values = si_values(parse(monkeypatch, path, command, param, typed), param)
    assert values and values == pytest.approx([math.radians(60)] * len(values))


def test_the_walk_finds_the_options_people_type_angles_into():
    found = {(" ".join(path), param.name) for path, _, param in angular_params()}
    assert {("poses set", "speed"), ("poses offset", "rx"), ("run-poses", "speed"), ("export-urscript", "max_travel"),
            ("fk", "joints"), ("ik", "near"), ("record-pose", "acceleration"), ("demo", "speed")} <= found


@pytest.fixture
def program(tmp_path, run_in_process):
    """A cell program: the example poses, 'demo-2' a linear move."""
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    assert run_in_process("poses", "set", "demo-2", "--move", "linear").returncode == 0
    return PoseStore(tmp_path / "poses.json")


def speed_of(store, name):
    return store.get_step(name).motion.speed


@pytest.mark.parametrize("args", [("--deg", "poses", "set", "demo-1", "--speed", "60"),
                                  ("poses", "set", "demo-1", "--speed", "60", "--deg"),
                                  ("poses", "set", "demo-1", "--speed", "60deg/s"),
                                  ("poses", "set", "demo-1", "--speed", "60°/s")])
def test_a_joint_speed_in_degrees_is_stored_in_radians(run_in_process, program, args):
    result = run_in_process(*args)
    assert result.returncode == 0, result.stderr
    assert speed_of(program, "demo-1") == pytest.approx(math.radians(60))
    assert "60 °/s" in run_in_process("--deg", "poses", "list").stdout


def test_a_linear_speed_in_mm_per_s_is_stored_in_metres_per_second(run_in_process, program):
    assert run_in_process("poses", "set", "demo-2", "--speed", "250mm/s").returncode == 0
    assert speed_of(program, "demo-2") == pytest.approx(0.25)
    assert run_in_process("--mm", "poses", "set", "demo-2", "--speed", "100").returncode == 0
    assert speed_of(program, "demo-2") == pytest.approx(0.1)
    assert "100 mm/s" in run_in_process("poses", "list").stdout


@pytest.mark.parametrize("args, fragments", [
    (("poses", "set", "demo-2", "--speed", "50"),
     ["step 'demo-2' (waypoint): speed 50000 mm/s is outside the ur3's range for a linear move, 1 mm/s to 1000 mm/s",
      "--speed 250mm/s"]),
    (("poses", "set", "demo-1", "--speed", "60"),
     ["speed 60 rad/s is outside the ur3's range for a joint move, 0.001 rad/s to 3.1416 rad/s"]),
    (("--deg", "poses", "set", "demo-1", "--speed", "500"), ["speed 500 °/s", "0.06 °/s to 180 °/s"]),
    (("poses", "set", "demo-2", "--speed", "60deg/s"),
     ["step 'demo-2' (waypoint) is a linear move", "'deg/s' is a unit of joint speed", "--move joint"]),
    (("poses", "set", "demo-1", "--speed", "250mm/s"), ["is a joint move", "--move linear"]),
    (("poses", "set", "demo-2", "--acceleration", "9m/s^2"), ["acceleration 9000 mm/s²", "to 4000 mm/s²"]),
    (("poses", "offset", "x", "--from", "demo-1", "--z", "5 km"), ["--z", "'km' is not a unit ur3dq knows"]),
    # a value out of its bounds is named as typed, in the typed units (never its SI value, -0.0872664...)
    (("--deg", "--mm", "poses", "set", "demo-1", "--speed", "-5"),
     ["step 'demo-1' (waypoint): --speed must be more than 0 °/s, got -5 °/s"]),
    (("--deg", "--mm", "poses", "set", "demo-2", "--speed", "-5"), ["--speed must be more than 0 mm/s, got -5 mm/s"]),
    (("--deg", "--mm", "poses", "set", "demo-1", "--blend", "-5"),
     ["step 'demo-1' (waypoint): --blend must be from 0 mm to 1000 mm, got -5 mm"]),
    (("--deg", "--mm", "poses", "set", "demo-1", "--blend", "1e300"),
     ["--blend must be from 0 mm to 1000 mm, got 1e300 mm"]),
    (("--mm", "poses", "set", "demo-1", "--blend", "-0.5cm"), ["--blend must be from 0 mm to 1000 mm, got -0.5cm"]),
    (("poses", "add-step", "wait", "1e-300"), ["a wait lasts at least 0.002 s (one control cycle), got 1e-300 s"]),
])
def test_out_of_range_or_wrong_unit_is_refused_when_set(run_in_process, program, args, fragments):
    before = program.path.read_bytes()
    assert_one_line_error(run_in_process(*args), 4, *fragments)
    assert program.path.read_bytes() == before


def test_offsets_take_units_and_follow_deg_and_mm(run_in_process, program):
    assert run_in_process("--deg", "poses", "offset", "tilt", "--from", "demo-1", "--rx", "5").returncode == 0
    assert run_in_process("poses", "offset", "up", "--from", "demo-1", "--z", "-50mm", "--ry", "0.1").returncode == 0
    assert run_in_process("poses", "offset", "up2", "--from", "demo-1", "--z", "-50", "--mm").returncode == 0
    assert program.get_step("tilt").offset[3] == pytest.approx(math.radians(5))
    assert program.get_step("up").offset[2:5] == pytest.approx((-0.05, 0.0, 0.1))
    assert program.get_step("up2").offset[2] == pytest.approx(-0.05)
    shown = json.loads(run_in_process("poses", "show", "tilt", "--json").stdout)["step"]
    assert shown["offset"][3] == pytest.approx(math.radians(5))   # JSON stays SI under --deg
    shown_text = run_in_process("poses", "show", "tilt", "--deg").stdout
    assert "5.000°" in shown_text and shown_text.count("│ move ") == 1


def test_run_options_follow_deg_after_the_command(run_in_process, tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    script = run_in_process("export-urscript", "--speed", "30", "--deg").stdout
    assert f"v={math.radians(30)!r}"[:12] in script.replace(" ", ""), script[:2000]
    assert_one_line_error(run_in_process("export-urscript", "--speed", "250mm/s"), 4, "--speed takes a joint speed")


def test_a_typed_value_keeps_the_units_it_was_typed_in():
    value = TypedValue("60", __import__("ur3dq.units").units.Units(angle="deg"), "--speed")
    assert value.si(ANGULAR_SPEED) == pytest.approx(math.radians(60))
    assert value.si(LENGTH) == 60.0   # a bare length stays metres: --deg never changes a length


@pytest.mark.parametrize("options, reach", [((), "at most 0.4569 m"), (("--mm",), "at most 456.9 mm")])
def test_an_unreachable_pose_is_explained_in_the_chosen_units(run_cli, options, reach):
    result = run_cli(*options, "ik", "0.9m", "0", "0", "0", "0", "0")
    assert result.returncode == 4 and reach in result.stderr, result.stderr
