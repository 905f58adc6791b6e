"""URScript for the nodes of a PolyScope program that have no ur3dq step, generated the way PolyScope generates it
when play is pressed (`import-urp --keep-script`).

The statements are PolyScope's: `if (expr):` / `elif` / `else:` ... `end`, `while (True):`, a counted loop with its
`Loop_N` counter, `global name=expr` for an assignment, a script line as it is and a script file's contents as
saved, `thread T(): ... end` with `threadId_T = run T()`, a sub-program's `def` before its call, popups,
`halt`, waits (`sleep(t)`; `while (not(...)): sync() end`) and setters. A fixed waypoint under MoveJ moves with
`movej(get_inverse_kin(p, qnear=q), a=, v=)` and under MoveL/MoveP with `movel(p, ...)`/`movep(p, ...)`, p the TCP
pose its recorded joints give on the arm it was saved on, as PolyScope's own generated scripts do; a relative
waypoint with `pose_add(get_target_tcp_pose(), pose_sub(to, from))`. PolyScope's `$ N "label"` line markers
become `# label` comments (free text never reaches a string literal unescaped).
"""
from __future__ import annotations

from collections.abc import Callable
from xml.etree.ElementTree import Element

from polyscope_format.nodes import analog_comparison, digital_on, grouped_if_chains, if_branches, if_kind
from polyscope_format.script_lines import ScriptLines
from ur3dq import urscript
from ur3dq.polyscope.nodes import NodeError, Program, loop_count, number_field, read_pin, write_pin

# (joints, tcp offset, TCP pose) of a recorded position element; NodeError when it records none
PositionReader = Callable[[Element, str], tuple[list[float], list[float], list[float]]]
COMMANDS = {"MoveJ": "movej", "MoveL": "movel", "MoveP": "movep"}


class KeptScriptWriter(ScriptLines):
    """Writes the URScript of unsupported nodes; one writer per program (it numbers loop counters)."""

    def __init__(self, program: Program, positions: PositionReader) -> None:
        super().__init__()
        self.program = program
        self.positions = positions
        self.loops = 0

    def script(self, nodes: list[Element], path: str) -> str:
        """The URScript of `nodes` (one node, or an If with its ElseIf/Else siblings) at `path`."""
        self.lines, self.depth = [], 0
        self.block(nodes, path.rsplit("/", 1)[0] if "/" in path else "")
        return "\n".join(self.lines) + "\n"

    def waypoint_script(self, move: Element, waypoint: Element, path: str) -> str:
        """The URScript of one waypoint of the Move `move` (a waypoint ur3dq has no step for)."""
        self.lines, self.depth = [], 0
        self._waypoint(move, waypoint, path)
        return "\n".join(self.lines) + "\n"

    def marker(self, label: str) -> None:
        """PolyScope's `$ N "label"` line marker, written as a comment."""
        self.line(f"# {urscript.comment_text(label)}")

    def block(self, nodes: list[Element], parent: str) -> None:
        """Translate `nodes` in order (an If takes the ElseIf/Else siblings that follow it)."""
        for group in grouped_if_chains(nodes):
            if if_kind(group[0]) == "If":
                self._if_chain(group, parent)
            else:
                self.node(group[0], parent)

    def node(self, node: Element, parent: str) -> None:
        path = self.program.path_to(parent, node)
        handler = _HANDLERS.get(node.tag)
        if handler is None or if_kind(node) in ("ElseIf", "Else"):
            if if_kind(node):
                raise NodeError(path, f"{if_kind(node)} without its If")
            if node.tag == "Contributed":
                raise NodeError(path, "a URCap node's URScript comes from its URCap on the pendant")
            raise NodeError(path, f"ur3dq cannot generate <{node.tag}>")
        handler(self, node, path)

    def _no_continuous_check(self, node: Element, path: str) -> None:
        if node.get("checkContinuously", "false").lower() == "true":
            raise NodeError(path, f"a continuously checked {node.tag} cannot be kept as URScript")

    def _if_chain(self, chain: list[Element], parent: str) -> None:
        first = chain[0]
        then_nodes, branches = if_branches(chain, self.program.children(first))
        for number, branch in enumerate(branches):
            path = self.program.path_to(parent, branch)
            self._no_continuous_check(branch, path)
            kind = if_kind(branch) if number else "If"
            if kind == "Else":
                self.line("else:")
            else:
                self.line(f"{'if' if kind == 'If' else 'elif'} ({self.program.expression(branch, path)}):")
            with self.indented():
                self.marker(self.program.label(branch))
                self.block(then_nodes if branch is first else self.program.children(branch), path)
        self.line("end")

    def loop(self, node: Element, path: str) -> None:
        self._no_continuous_check(node, path)
        kind = node.get("type", "Forever")
        increment = None
        if kind == "Forever":
            self.line("while (True):")
        elif kind in ("Counting", "Count", "Times"):
            self.loops += 1
            increment = f"Loop_{self.loops}"
            self.line(f"{increment} = 0")
            self.line(f"while ({increment} < {loop_count(node, path)}):")
        elif kind in ("While", "Expression", "Condition"):
            self.line(f"while ({self.program.expression(node, path)}):")
        else:
            raise NodeError(path, f"loop type {kind!r} is not one ur3dq knows")
        with self.indented():
            self.marker(self.program.label(node))
            self.block(self.program.children(node), path)
            if increment:
                self.line(f"{increment} = {increment} + 1")
        self.line("end")

    def wait(self, node: Element, path: str) -> None:
        kind = node.get("type", "Sleep")
        self.marker(self.program.label(node))
        if kind == "Sleep":
            self.line(urscript.sleep_statement(number_field(node, "waitTime", path)))
            return
        if kind == "DigitalInput":
            condition = f"{read_pin(self.program.pin(node, path), path)} == {digital_on(node)}"
        elif kind == "AnalogInput":
            threshold = urscript.format_number(number_field(node, "analogValue", path))
            condition = f"{read_pin(self.program.pin(node, path), path)} {analog_comparison(node)} {threshold}"
        elif kind in ("Condition", "Expression"):
            condition = self.program.expression(node, path)
        else:
            raise NodeError(path, f"wait type {kind!r} is not one ur3dq knows")
        self.line(f"while (not({condition})):")
        with self.indented():
            self.line("sync()")
        self.line("end")

    def set_output(self, node: Element, path: str) -> None:
        kind = node.get("type", "DigitalOutput")
        self.marker(self.program.label(node))
        if kind == "NoAction":
            return
        pin = self.program.pin(node, path)
        if kind == "DigitalOutput":
            value = str(digital_on(node))
        elif kind == "AnalogOutput":
            value = urscript.format_number(number_field(node, "analogValue", path))
        elif kind in ("Expression", "ExpressionOutput"):
            value = self.program.expression(node, path)
        else:
            raise NodeError(path, f"set type {kind!r} is not one ur3dq knows")
        self.line(write_pin(pin, value, path))

    def script_node(self, node: Element, path: str) -> None:
        self.marker(self.program.label(node))
        if node.get("type", "Line") == "File":
            contents = node.findtext("cachedContents")
            if contents is None:
                raise NodeError(path, "the script file's contents are not in the program")
            self.line(contents.rstrip("\n").expandtabs(2))
            return
        self.line(self.program.expression(node, path))

    def assignment(self, node: Element, path: str) -> None:
        if node.get("valueSource", "Expression") != "Expression":
            raise NodeError(path, "an assignment from operator input cannot run without an operator")
        name = self.program.variable(node.find("variable"), path)
        self.marker(self.program.label(node))
        self.line(f"global {name}={self.program.expression(node, path)}")

    def popup(self, node: Element, path: str) -> None:
        kind = node.get("type", "Message")
        if kind not in ("Message", "Warning", "Error"):
            raise NodeError(path, f"popup type {kind!r} is not one ur3dq knows")
        message = node.get("message") or node.findtext("message") or ""
        self.marker(self.program.label(node))
        self.line(f"popup({urscript.sanitise_text(message, 'the popup text')}, \"{kind}\", {kind == 'Warning'}, "
                  f"{kind == 'Error'}, blocking=True)")
        if node.get("haltProgram", "false").lower() == "true":
            self.line("halt")

    def comment(self, node: Element, path: str) -> None:
        self.marker(self.program.label(node))

    def folder(self, node: Element, path: str) -> None:
        self.marker(self.program.label(node))
        self.block(self.program.children(node), path)

    def init_variables(self, node: Element, path: str) -> None:
        self.marker("Init Variables")
        self.block(self.program.children(node), path)

    def halt(self, node: Element, path: str) -> None:
        self.marker("Halt")
        self.line("halt")

    def thread(self, node: Element, path: str) -> None:
        name = _identifier(node.get("name") or "Thread_1", path)
        self.line(f"thread {name}():")
        with self.indented():
            if node.get("runOnlyOnce", "false").lower() == "true":
                self.marker(name)
                self.block(self.program.children(node), path)
            else:
                self.line("while (True):")
                with self.indented():
                    self.marker(name)
                    self.block(self.program.children(node), path)
                    self.line("sync()")
                self.line("end")
        self.line("end")
        self.line(f"threadId_{name} = run {name}()")

    def call(self, node: Element, path: str) -> None:
        holder = node.find("subprogram")
        if holder is None:
            raise NodeError(path, "the call names no sub-program")
        definition = self.program.tree.resolve(holder)
        name = _identifier(definition.get("name") or "", path)
        self.line(f"def {name}():")
        with self.indented():
            self.marker(name)
            self.block(self.program.children(definition), path)
        self.line("end")
        self.marker(self.program.label(node))
        self.line(f"{name}()")

    def move(self, node: Element, path: str) -> None:
        kind = node.get("motionType", "MoveJ")
        if kind not in COMMANDS:
            raise NodeError(path, f"motion type {kind!r} cannot be kept as URScript")
        self.marker(kind)
        for child in self.program.children(node):
            if child.tag == "Waypoint":
                self._waypoint(node, child, self.program.path_to(path, child))
            else:
                self.block([child], path)

    def _waypoint(self, move: Element, waypoint: Element, path: str) -> None:
        kind = move.get("motionType", "MoveJ")
        joint = kind == "MoveJ"
        speed = number_field(move, "speed", path) if move.get("speed") else (1.0471975511965976 if joint else 0.25)
        acceleration = number_field(move, "acceleration", path) if move.get("acceleration") else \
            (1.3962634015954636 if joint else 1.2)
        blend = number_field(move, "blendRadius", path) if move.get("blendRadius") else 0.0
        parameters = waypoint.find("motionParameters")
        prefix = "joint" if joint else "cartesian"
        if parameters is not None:
            speed = number_field(parameters, prefix + "Speed", path) if parameters.get(prefix + "Speed") else speed
            acceleration = number_field(parameters, prefix + "Acceleration", path) \
                if parameters.get(prefix + "Acceleration") else acceleration
            blend = number_field(parameters, "blendRadius", path) if parameters.get("blendRadius") else blend
        arguments = f"a={urscript.format_number(acceleration)}, v={urscript.format_number(speed)}" + \
            (f", r={urscript.format_number(blend)}" if blend > 0 else "")
        self.marker(self.program.label(waypoint))
        target = self._target(move, waypoint, path, joint)
        self.line(f"{COMMANDS[kind]}({target}, {arguments})")

    def _target(self, move: Element, waypoint: Element, path: str, joint: bool) -> str:
        kind = waypoint.get("type", "Fixed")
        if kind == "Fixed":
            q, tcp, pose = self.positions(_child(waypoint, "position", path), path)
            if move.get("useActiveTCP", "true").lower() == "false":
                self.line(urscript.set_tcp_statement(tcp))
            if joint:
                return f"get_inverse_kin({urscript.format_pose(pose)}, qnear={urscript.format_vector(q)})"
            return urscript.format_pose(pose)
        if kind == "Relative":
            start = self.positions(_child(waypoint, "fromPosition", path), path)[2]
            end = self.positions(_child(waypoint, "toPosition", path), path)[2]
            return f"pose_add(get_target_tcp_pose(), pose_sub({urscript.format_pose(end)}, " \
                   f"{urscript.format_pose(start)}))"
        if kind == "Variable":
            return self.program.variable(waypoint.find("variable"), path)
        raise NodeError(path, f"waypoint type {kind!r} is not one ur3dq knows")


def _child(node: Element, tag: str, path: str) -> Element:
    child = node.find(tag)
    if child is None:
        raise NodeError(path, f"the waypoint has no <{tag}>")
    return child


def _identifier(name: str, path: str) -> str:
    try:
        return urscript.check_identifier(name)
    except ValueError:
        raise NodeError(path, f"{name!r} is not a name URScript can define") from None


_HANDLERS: dict[str, Callable[[KeptScriptWriter, Element, str], None]] = {
    "Move": KeptScriptWriter.move, "Set": KeptScriptWriter.set_output, "Wait": KeptScriptWriter.wait,
    "Loop": KeptScriptWriter.loop, "Script": KeptScriptWriter.script_node, "Popup": KeptScriptWriter.popup,
    "Comment": KeptScriptWriter.comment, "Folder": KeptScriptWriter.folder,
    "Assignment": KeptScriptWriter.assignment, "Halt": KeptScriptWriter.halt, "Thread": KeptScriptWriter.thread,
    "CallSubProgram": KeptScriptWriter.call, "InitVariablesNode": KeptScriptWriter.init_variables,
}
