"""A PolyScope program tree -> one URScript program, the way PolyScope generates it when play is pressed.

The program becomes `def <name>():` (the program's name; a name starting with a digit gets a `P` in front, as
PolyScope writes it), with, in this order: sub-program definitions, the InitVariablesNode's and BeforeStart's nodes,
the threads started, then the main program's nodes in order — inside `while (True):` unless the program runs only
once. Each node is preceded by PolyScope's `$ N "label"` marker. Nodes (both PolyScope 3.x and 5.x spellings):

======================  ===========================================================================================
Move / Waypoint         moves.py: `movej(q, a, v, r)`, `movel(pose, ...)`, `movep(pose, ...)` per waypoint
Set                     `set_standard_digital_out(n, True)`, `set_configurable_digital_out`, `set_tool_digital_out`,
                        `set_standard_analog_out(n, x)`, boolean/int/float output registers
Wait                    `sleep(t)`; an input, analog input or expression: `while (not(...)): sync() end`
Loop                    `while (True):`; a counted loop with its counter `Loop_N`; `while (expr):`
If / ElseIf / Else      `if (expr):` / `elif (expr):` / `else:` ... `end` (an ElseIf/Else follows its If as a sibling
                        in the tree, or sits in the If's children)
Script                  a line's expression as one line; a file's cached contents as they are
Popup                   `popup("text", "Message|Warning|Error", warning, error, blocking=True)`, `halt` after it
                        when the node halts the program
Comment, Folder         `# text`; the folder's nodes in order
Assignment              `global name=expr`
Halt                    `halt`
Thread                  `thread <name>(): while (True): ... sync() end end` (no loop when it runs only once) and
                        `threadId_<name> = run <name>()` before the main program
CallSubProgram          `Name()`, with `def Name():` among the definitions
Contributed             URCap nodes: the External Control URCap (external_control.py); others are refused
======================  ===========================================================================================

Anything else (an unknown node, a continuously checked If/Loop, an operator-input assignment, a renamed I/O pin)
raises UrpError naming the node's place in the tree: the simulator refuses a program it would not run as PolyScope.

>>> program_urscript(read_urp("wait_program.urp"))                     # doctest: +SKIP
'def wait_program():\\n  while (True):\\n    $ 1 "Robot Program"\\n    $ 2 "Wait: 0.01"\\n    sleep(0.01)\\n  end...'
"""
import re
from collections.abc import Callable
from typing import Any
from xml.etree.ElementTree import Element

from polyscope_format.nodes import (
    analog_comparison,
    digital_on,
    field_text,
    grouped_if_chains,
    if_branches,
    if_kind,
    node_children,
)
from polyscope_format.urp_file import ProgramTree

from . import moves
from .errors import UrpError
from .expressions import expression_text, pin_name, read_pin, variable_name, write_pin
from .script_writer import ScriptWriter, number, safe_text, string_literal

# A URCap node's script: called with the tree and the <Contributed> element; returns URScript text.
ContributedScript = Callable[[ProgramTree, Element], str]


def program_urscript(tree: ProgramTree, contributed: ContributedScript | None = None) -> str:
    """The URScript PolyScope runs for `tree`; `contributed` writes URCap nodes (None: such nodes are refused)."""
    return Translation(tree, contributed).program()


def program_def_name(name: str) -> str:
    """A program name as the name of its URScript `def` (`5exIF` -> `P5exIF`, spaces and signs -> `_`)."""
    cleaned = re.sub(r"\W", "_", name, flags=re.ASCII) or "unnamed"
    return "P" + cleaned if cleaned[0].isdigit() else cleaned


class Translation:
    """One translation of a program tree (what `program_urscript` runs); node handlers write into `self.writer`."""

    def __init__(self, tree: ProgramTree, contributed: ContributedScript | None = None) -> None:
        self.tree = tree
        self.contributed = contributed
        self.writer = ScriptWriter()
        self.loop_counters = 0
        self.subprograms: dict[Element, str] = {}

    # ------------------------------------------------------------------------------------------ program
    def program(self) -> str:
        """The whole `def <name>(): ... end` program."""
        sections = self._top_level()
        main = sections.get("MainProgram")
        if main is None:
            raise UrpError(f"{self.tree.source}: not a PolyScope program (it has no MainProgram node)")
        self._collect_subprograms()
        for kind in ("InitVariablesNode", "SpecialSequence", "BeforeStart"):
            for section in sections.get(kind + "*", []):
                self._section(section, "BeforeStart" if kind != "InitVariablesNode" else "Init Variables")
        before_start = self.writer.text()
        threads = self._threads(sections.get("Thread*", []))
        self.writer = ScriptWriter(self.writer.next_marker)
        self._main(main)
        main_text = self.writer.text()
        definitions = self._definitions()
        program = ScriptWriter()
        program.line(f"def {program_def_name(self.tree.name)}():")
        with program.indented():
            for text in (definitions, before_start, threads, main_text):
                if text:
                    program.line(text.rstrip("\n"))
        program.line("end")
        return program.text()

    def _top_level(self) -> dict[str, Any]:
        children = self.tree.root.find("children")
        if children is None:
            raise UrpError(f"{self.tree.source}: not a PolyScope program (<URProgram> has no <children>)")
        sections: dict[str, Any] = {}
        for element in children:
            element = self.tree.resolve(element) if element.tag != "SubProgram" else element
            if element.tag == "MainProgram":
                sections["MainProgram"] = element
            elif element.tag in ("InitVariablesNode", "SpecialSequence", "BeforeStart", "Thread"):
                sections.setdefault(element.tag + "*", []).append(element)
            elif element.tag != "SubProgram":
                raise UrpError(f"{self.tree.path_of(element)}: top-level node <{element.tag}> is not supported "
                               "by sim_ursim")
        return sections

    def _section(self, section: Element, label: str) -> None:
        if section.tag == "SpecialSequence" and section.get("type", "BeforeStart") != "BeforeStart":
            raise UrpError(f"{self.tree.path_of(section)}: special sequence {section.get('type')!r} is not "
                           "supported by sim_ursim")
        nodes = self.children_of(section)
        if not nodes:
            return
        self.writer.marker(label)
        self.block(nodes)

    def _main(self, main: Element) -> None:
        forever = main.get("runOnlyOnce", "false").lower() != "true"
        if forever:
            self.writer.line("while (True):")
            with self.writer.indented():
                self._main_body(main)
            self.writer.line("end")
        else:
            self._main_body(main)

    def _main_body(self, main: Element) -> None:
        self.writer.marker("Robot Program")
        self.block(self.children_of(main))

    def _threads(self, threads: list[Element]) -> str:
        """`thread` definitions and their `run`, started after BeforeStart, before the main program."""
        saved, self.writer = self.writer, ScriptWriter(self.writer.next_marker)
        for number_, thread in enumerate(threads, 1):
            name = program_def_name(thread.get("name") or thread.get("threadName") or f"Thread_{number_}")
            self.writer.line(f"thread {name}():")
            with self.writer.indented():
                if thread.get("runOnlyOnce", "false").lower() == "true":
                    self.writer.marker(name)
                    self.block(self.children_of(thread))
                else:
                    self._thread_loop(thread, name)
            self.writer.line("end")
            self.writer.line(f"threadId_{name} = run {name}()")
        text = self.writer.text()
        saved.next_marker, self.writer = self.writer.next_marker, saved
        return text

    def _thread_loop(self, thread: Element, name: str) -> None:
        """A thread's nodes run again and again (a `sync()` each time round, so a pass that takes no time does not
        hog the interpreter)."""
        self.writer.line("while (True):")
        with self.writer.indented():
            self.writer.marker(name)
            self.block(self.children_of(thread))
            self.writer.line("sync()")
        self.writer.line("end")

    def _collect_subprograms(self) -> None:
        for element in self.tree.root.iter():
            if element.tag in ("SubProgram", "subprogram"):
                definition = self.tree.resolve(element)
                if definition not in self.subprograms:
                    name = definition.get("name")
                    if not name:
                        raise UrpError(f"{self.tree.path_of(definition)}: the sub-program has no name")
                    self.subprograms[definition] = program_def_name(name)

    def _definitions(self) -> str:
        """`def Name():` for every sub-program (numbered after the main program's markers, as PolyScope does)."""
        saved, self.writer = self.writer, ScriptWriter(self.writer.next_marker)
        for definition, name in self.subprograms.items():
            self.writer.line(f"def {name}():")
            with self.writer.indented():
                self.writer.marker(name)
                self.block(self.children_of(definition))
            self.writer.line("end")
        text = self.writer.text()
        self.writer = saved
        return text

    # ------------------------------------------------------------------------------------------ blocks
    def children_of(self, element: Element) -> list[Element]:
        """The nodes under `element`'s `<children>` (references followed, placeholders dropped)."""
        return node_children(self.tree, element)

    def block(self, nodes: list[Element]) -> None:
        """Translate `nodes` in order (an If takes the ElseIf/Else siblings that follow it)."""
        for group in grouped_if_chains(nodes):
            node = group[0]
            if if_kind(node) == "If":
                self.located(node, self._if_chain, group)
            elif if_kind(node) in ("ElseIf", "Else"):
                raise UrpError(f"{self.tree.path_of(node)}: {if_kind(node)} without its If")
            else:
                self.located(node, self.node, node)

    def located(self, node: Element, translate: Callable[..., None], *arguments: object) -> None:
        """Run `translate(*arguments)`; an error without a place in the tree gets `node`'s."""
        try:
            translate(*arguments)
        except (UrpError, ValueError) as error:
            text = str(error)
            if text.startswith(("URProgram", self.tree.source)):
                raise
            raise UrpError(f"{self.tree.path_of(node)}: {text}") from None

    def node(self, node: Element) -> None:
        """Translate one node (not an If chain: see `block`)."""
        handler = _HANDLERS.get(node.tag)
        if handler is None:
            raise UrpError(f"{self.tree.path_of(node)}: node <{node.tag}> is not supported by sim_ursim")
        handler(self, node)

    # ------------------------------------------------------------------------------------------ control flow
    def _if_chain(self, branches: list[Element]) -> None:
        first = branches[0]
        then_nodes, branches = if_branches(branches, self.children_of(first))
        for number_, branch in enumerate(branches):
            kind = if_kind(branch) if number_ else "If"
            self._no_continuous_check(branch)
            if kind == "Else":
                self.writer.line("else:")
                label = "Else"
            else:
                condition = expression_text(self.tree, branch.find("expression"), branch)
                self.writer.line(f"{'if' if kind == 'If' else 'elif'} ({condition}):")
                label = f"{kind} {condition}"
            with self.writer.indented():
                self.writer.marker(label)
                self.block(then_nodes if branch is first else self.children_of(branch))
        self.writer.line("end")

    def _no_continuous_check(self, node: Element) -> None:
        if node.get("checkContinuously", "false").lower() == "true":
            raise UrpError(f"{self.tree.path_of(node)}: a continuously checked {node.tag} is not supported by "
                           "sim_ursim")

    def loop(self, node: Element) -> None:
        """Loop forever, a number of times (counter `Loop_N`), or while an expression holds."""
        self._no_continuous_check(node)
        kind = node.get("type", "Forever")
        if kind == "Forever":
            self.writer.line("while (True):")
            self._loop_body(node, "Loop")
        elif kind in ("Counting", "Count", "Times"):
            self.loop_counters += 1
            counter = f"Loop_{self.loop_counters}"
            times = int(_number_field(self.tree, node, ("count", "loopCount", "times", "iterations")))
            self.writer.line(f"{counter} = 0")
            self.writer.line(f"while ({counter} < {times}):")
            self._loop_body(node, f"Loop {times} times", increment=counter)
        elif kind in ("While", "Expression", "Condition"):
            condition = expression_text(self.tree, node.find("expression"), node)
            self.writer.line(f"while ({condition}):")
            self._loop_body(node, f"Loop {condition}")
        else:
            raise UrpError(f"{self.tree.path_of(node)}: loop type {kind!r} is not supported by sim_ursim")

    def _loop_body(self, node: Element, label: str, increment: str | None = None) -> None:
        with self.writer.indented():
            self.writer.marker(label)
            self.block(self.children_of(node))
            if increment:
                self.writer.line(f"{increment} = {increment} + 1")
        self.writer.line("end")

    # ------------------------------------------------------------------------------------------ statements
    def wait(self, node: Element) -> None:
        """Sleep, or wait (one sync per cycle) until an input, analog input or expression holds."""
        kind = node.get("type", "Sleep")
        if kind == "Sleep":
            seconds = _number_field(self.tree, node, ("waitTime",))
            self.writer.marker(f"Wait: {number(seconds)}")
            self.writer.line(f"sleep({number(seconds)})")
            return
        if kind == "DigitalInput":
            condition = f"{_read(self, node)} == {digital_on(node)}"
        elif kind == "AnalogInput":
            threshold = number(_number_field(self.tree, node, ("analogValue",)))
            condition = f"{_read(self, node)} {analog_comparison(node)} {threshold}"
        elif kind in ("Condition", "Expression"):
            condition = expression_text(self.tree, node.find("expression"), node)
        else:
            raise UrpError(f"{self.tree.path_of(node)}: wait type {kind!r} is not supported by sim_ursim")
        self.writer.marker(f"Wait {condition}")
        self.writer.line(f"while (not({condition})):")
        with self.writer.indented():
            self.writer.line("sync()")
        self.writer.line("end")

    def set_output(self, node: Element) -> None:
        """A digital or analog output (or output register) set to the node's value."""
        kind = node.get("type", "DigitalOutput")
        if kind == "NoAction":
            self.writer.marker("Set")
            return
        pin = pin_name(self.tree, node.find("pin"), node)
        if kind == "DigitalOutput":
            value = str(digital_on(node))
        elif kind == "AnalogOutput":
            value = number(_number_field(self.tree, node, ("analogValue",)))
        elif kind in ("Expression", "ExpressionOutput"):
            value = expression_text(self.tree, node.find("expression"), node)
        else:
            raise UrpError(f"{self.tree.path_of(node)}: set type {kind!r} is not supported by sim_ursim")
        self.writer.marker(f"Set {pin}={value}")
        self.writer.line(write_pin(pin, value))

    def script(self, node: Element) -> None:
        """A script line (its expression) or a script file (its cached contents, as saved in the program)."""
        if node.get("type", "Line") == "File":
            contents = node.findtext("cachedContents")
            if contents is None:
                raise UrpError(f"{self.tree.path_of(node)}: the script file's contents are not in the program")
            self.writer.marker(f"Script: {(node.findtext('file') or '').split('/')[-1]}")
            self.writer.line(contents.rstrip("\n").expandtabs(2))
            return
        line = expression_text(self.tree, node.find("expression"), node)
        self.writer.marker(line)
        self.writer.line(line)

    def assignment(self, node: Element) -> None:
        if node.get("valueSource", "Expression") != "Expression":
            raise UrpError(f"{self.tree.path_of(node)}: an assignment from {node.get('valueSource')!r} (operator "
                           "input) is not supported by sim_ursim")
        name = variable_name(self.tree, node.find("variable"), node)
        value = expression_text(self.tree, node.find("expression"), node)
        self.writer.marker(f"{name}:={value}")
        self.writer.line(f"global {name}={value}")

    def popup(self, node: Element) -> None:
        kind = node.get("type", "Message")
        if kind not in ("Message", "Warning", "Error"):
            raise UrpError(f"{self.tree.path_of(node)}: popup type {kind!r} is not supported by sim_ursim")
        message = node.get("message") or node.findtext("message") or ""
        self.writer.marker(f"Popup: {message}")
        flags = f"{kind == 'Warning'}, {kind == 'Error'}"
        self.writer.line(f"popup({string_literal(message)}, {string_literal(kind)}, {flags}, blocking=True)")
        if node.get("haltProgram", "false").lower() == "true":
            self.writer.line("halt")

    def comment(self, node: Element) -> None:
        text = node.get("comment") or node.findtext("comment") or ""
        self.writer.marker(f"'{text}'")
        self.writer.line(f"# {safe_text(text)}")

    def folder(self, node: Element) -> None:
        self.writer.marker(node.get("name") or "Folder")
        self.block(self.children_of(node))

    def halt(self, node: Element) -> None:
        self.writer.marker("Halt")
        self.writer.line("halt")

    def call(self, node: Element) -> None:
        definition = node.find("subprogram")
        if definition is None:
            raise UrpError(f"{self.tree.path_of(node)}: the call names no sub-program")
        name = self.subprograms[self.tree.resolve(definition)]
        self.writer.marker(f"Call {name}")
        self.writer.line(f"{name}()")

    def urcap(self, node: Element) -> None:
        what = node.get("strategyProgramNodeType") or node.get("strategyClass") or "?"
        if self.contributed is None:
            raise UrpError(f"{self.tree.path_of(node)}: URCap node {what!r} is not supported by sim_ursim")
        self.writer.marker(what)
        self.writer.line(self.contributed(self.tree, node).rstrip("\n"))

    def move(self, node: Element) -> None:
        moves.translate_move(self, node)

    def thread_inside(self, node: Element) -> None:
        raise UrpError(f"{self.tree.path_of(node)}: a Thread must be at the top of the program tree")


def _number_field(tree: ProgramTree, node: Element, names: tuple[str, ...]) -> float:
    for name in names:
        text = field_text(node, name)
        if text:
            try:
                return float(number(float(text)))
            except ValueError:
                raise UrpError(f"{tree.path_of(node)}: {name} {text!r} is not a number") from None
    raise UrpError(f"{tree.path_of(node)}: the node has no {names[0]}")


def _read(translation: Translation, node: Element) -> str:
    return read_pin(pin_name(translation.tree, node.find("pin"), node))


_HANDLERS: dict[str, Callable[[Translation, Element], None]] = {
    "Move": Translation.move,
    "Set": Translation.set_output,
    "Wait": Translation.wait,
    "Loop": Translation.loop,
    "Script": Translation.script,
    "Popup": Translation.popup,
    "Comment": Translation.comment,
    "Folder": Translation.folder,
    "Assignment": Translation.assignment,
    "Halt": Translation.halt,
    "CallSubProgram": Translation.call,
    "Contributed": Translation.urcap,
    "Thread": Translation.thread_inside,
}
