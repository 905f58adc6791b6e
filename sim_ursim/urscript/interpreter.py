"""URScript evaluation: programs, scopes, functions, threads, run-time errors.

`compile_program` turns a parsed script into a `Program` (definitions hoisted, names resolved as the controller
does before running). `Execution` runs one program: a main thread plus script threads sharing the globals.

Scoping (URScript rules): the program's top level is the global scope; inside a function or thread an assignment
writes an existing global unless the name was declared `local` there, otherwise it creates a local; `global x = v`
always writes the global. Lists and poses are values: assignment and argument passing copy them. `/` divides as
real numbers (7 / 2 = 3.5); `%` keeps integers.

Scheduling: like the controller, script threads do not run in parallel. A thread holds the execution's scheduler
lock while it runs statements and gives it up when it waits for physical time (sleep, sync, a move, join). As on the
controller, a thread that uses up its time slice with computation alone is suspended until the next control cycle
(frame); here the slice is `STATEMENTS_PER_SECOND × period` statements, at least MIN_STATEMENTS_PER_FRAME (200 on
CB3 and e-series: a step of URCL's External Control spline is about 55), which also bounds the CPU a busy loop
takes. Inside `enter_critical`/`exit_critical` the suspended thread keeps the lock, so no other script thread runs
in between. Any exception inside a script thread ends the program as a runtime error at the thread's line; calls
nested deeper than MAX_CALL_DEPTH (runaway recursion) are a stack overflow.
"""
import itertools
import logging
import threading
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass

from sim_ursim.urscript import nodes
from sim_ursim.urscript.operators import BINARY, NUMERIC_FAST_PATH, PLAIN_NUMBERS, require_number
from sim_ursim.urscript.script_thread import Cancelled, ThreadContext
from sim_ursim.urscript.values import Pose, ScriptError, copy_value, to_str, truth
from sim_ursim.vocabulary import CommandRefused

log = logging.getLogger("sim_ursim.urscript")

MAX_CALL_DEPTH = 100  # nested function calls of one script thread before the run-time error "stack overflow"
STACK_OVERFLOW = "runtime_error:stack overflow:"  # UR does not publish its controller's text for this error
KILLED_MOVE_DECELERATION = 4.0  # rad/s²: the arm's stop when the thread running its move is killed
BUILTIN_CONSTANTS = {"pi": 3.141592653589793}  # names a script may read without assigning them


class CompileError(ValueError):
    """The controller refuses the script before running it (e.g. an unknown name)."""

    def __init__(self, line, column, text):
        super().__init__(f"line {line}, column {column}: {text}")
        self.line = line
        self.column = column
        self.text = text


class URScriptRuntimeError(RuntimeError):
    """A run-time error at a source position; `text` is the runtime-exception message text."""

    def __init__(self, line, column, text):
        super().__init__(f"line {line}, column {column}: {text}")
        self.line = line
        self.column = column
        self.text = text


class _Return(Exception):
    def __init__(self, value: object):
        self.value = value


class _Break(Exception):
    pass


class _Continue(Exception):
    pass


class _Halt(Exception):
    pass


@dataclass(frozen=True)
class Program:
    """A compiled script: the statements the main thread runs, plus every function and thread definition."""

    name: str
    body: tuple
    functions: dict
    threads: dict
    secondary: bool


def _walk(node):
    """Every node below (and including) `node`, depth first, following tuples and tuple pairs."""
    stack = [node]
    while stack:
        item = stack.pop()
        if isinstance(item, tuple):
            stack.extend(item)
        elif isinstance(item, nodes.Node):
            yield item
            stack.extend(getattr(item, name) for name in item.__dataclass_fields__ if name not in ("line", "column"))


def compile_program(script: nodes.Script, builtin_names: Collection[str], default_name: str = "Unnamed") -> "Program":
    """nodes.Script -> Program; CompileError (line, column, controller text) for an unknown function or thread, or a
    variable that is assigned nowhere in the program (scopes are checked only when the program runs).

    A script that is exactly one `def` is that program; exactly one `sec` is a secondary program; anything else
    (statement lines, with or without definitions) runs top to bottom as one program named `default_name`.
    """
    body = script.body
    if len(body) == 1 and isinstance(body[0], nodes.FunctionDef) and not body[0].params:
        name, main, secondary = body[0].name, body[0].body, False
    elif len(body) == 1 and isinstance(body[0], nodes.SecDef):
        name, main, secondary = body[0].name, body[0].body, True
    else:
        name, main, secondary = default_name, body, False
    functions, threads, bound = {}, {}, set(BUILTIN_CONSTANTS)
    for node in _walk(main):
        if isinstance(node, nodes.FunctionDef):
            functions[node.name] = node
            bound.update(p.name for p in node.params)
        elif isinstance(node, nodes.ThreadDef):
            threads[node.name] = node
        elif isinstance(node, (nodes.Assign, nodes.GlobalDecl, nodes.LocalDecl)):
            bound.add(node.name)
    for node in _walk(main):
        if isinstance(node, nodes.Call) and node.name not in functions and node.name not in builtin_names:
            raise CompileError(node.line, node.column, f"compile_error_name_not_found:{node.name}:")
        if isinstance(node, nodes.Run) and node.thread not in threads:
            raise CompileError(node.line, node.column, f"compile_error_name_not_found:{node.thread}:")
        if isinstance(node, nodes.Name) and node.name not in bound:
            raise CompileError(node.line, node.column, f"compile_error_name_not_found:{node.name}:")
    return Program(name, main, functions, threads, secondary)


class Execution:
    """One run of a Program on a controller: globals, the scheduler lock, the main thread and script threads."""

    def __init__(self, program: "Program", controller, builtins: Mapping[str, Callable]):
        self.program = program
        self.controller = controller
        self.builtins = builtins
        self.globals: dict[str, object] = {}
        self.scheduler = threading.Lock()
        self.unpaused = threading.Event()
        self.unpaused.set()
        self.error: URScriptRuntimeError | None = None  # the first URScriptRuntimeError of any thread
        self.end_reason: str | None = None  # why the program ended, for the log: the first halt, error or stop
        self.holds_freedrive = False  # freedrive_mode() ran, end_freedrive_mode() not: freedrive ends with the program
        self._threads: dict[object, ThreadContext] = {}   # by handle (a script value: run's result, kill's operand)
        self._handles = itertools.count(1)
        self._contexts: list[ThreadContext] = []
        self._contexts_lock = threading.Lock()
        self._python_threads: set[int] = set()  # idents of the Python threads running this program's script threads
        self.main = self._new_context(program.name)

    def owns_current_thread(self) -> bool:
        """True when called from one of this program's script threads (which must not wait for themselves)."""
        return threading.get_ident() in self._python_threads

    def _new_context(self, name: str) -> ThreadContext:
        context = ThreadContext(self, name)
        context.running = True   # its thread is about to start: it owes the frame until it first waits (FrameTurn)
        self.controller.frame_turn.join(context)
        with self._contexts_lock:
            self._contexts.append(context)
        return context

    # --- control from the runtime (any Python thread)
    def cancel(self) -> None:
        """Stop every thread of this program as soon as it next checks (waits are interrupted at once)."""
        self.unpaused.set()
        with self._contexts_lock:
            contexts = list(self._contexts)
        for context in contexts:
            context.request_cancel()

    def run(self) -> URScriptRuntimeError | None:
        """Run the main thread to the end in the calling Python thread; returns the URScriptRuntimeError or None.

        Threads still running when the main thread ends are killed, as on the controller.
        """
        context = self.main
        self._python_threads.add(threading.get_ident())
        self.scheduler.acquire()
        context.set_running(True)
        try:
            self.exec_block(context, self.program.body)
            self._note_end("ran to its end")
        except _Halt:
            pass
        except Cancelled:
            self._note_end("stopped")
        except URScriptRuntimeError as error:
            self._record_error(error)
        except (_Return, _Break, _Continue):
            self._note_end("ran to its end")
        except Exception as error:  # noqa: BLE001 - whatever fails in a program ends it as a runtime error
            self._record_error(unexpected_error(context, error))
        finally:
            self.controller.release_speed_hold(context)  # an ended thread sends no next command
            context.done.set()
            context.set_running(False)
            self.controller.frame_turn.leave(context)
            self.scheduler.release()
            self.cancel()
        return self.error

    def _record_error(self, error: URScriptRuntimeError) -> None:
        if self.error is None:
            self.error = error
        self._note_end(f"failed: {error}")
        self.cancel()

    def _note_end(self, reason: str) -> None:
        """Keep the first reason the program ends for (a halt or error cancels the other threads afterwards)."""
        if self.end_reason is None:
            self.end_reason = reason

    # --- statements
    def exec_block(self, ctx: ThreadContext, body: Sequence[nodes.Node]) -> None:
        """Execute statements in order."""
        unpaused = self.unpaused
        for statement in body:
            if ctx.cancel.is_set() or not unpaused.is_set():
                ctx.check()
            ctx.time_slice()
            ctx.line = statement.line
            _STATEMENTS[type(statement)](self, ctx, statement)

    def _exec_expr(self, ctx, node):
        self.eval(ctx, node.expr)

    def _exec_assign(self, ctx, node):
        if node.name == "digital_out" and len(node.indices) == 1 and not self._bound(ctx, node.name):
            # The legacy I/O variable (urx's set_digital_out writes `digital_out[n]=b`): set as set_digital_out(n, b).
            self._eval_call(ctx, nodes.Call("set_digital_out", (node.indices[0], node.value), (), line=node.line,
                                            column=node.column))
            return
        value = copy_value(self.eval(ctx, node.value))
        if not node.indices:
            self._store(ctx, node.name, value)
            return
        container = self._load(ctx, node.name, node)
        indices = [self.eval(ctx, index) for index in node.indices]
        for index, index_node in zip(indices[:-1], node.indices[:-1]):
            container = _element(container, index, index_node)
        last = _checked_index(container, indices[-1], node.indices[-1])
        if isinstance(container, str):
            raise URScriptRuntimeError(node.line, node.column, "runtime_error:strings are immutable:")
        container[last] = _pose_element(value, node) if isinstance(container, Pose) else value

    def _exec_global(self, ctx, node):
        self.globals[node.name] = copy_value(self.eval(ctx, node.value))

    def _exec_local(self, ctx, node):
        value = copy_value(self.eval(ctx, node.value))
        if ctx.frames:
            ctx.frames[-1][node.name] = value
        else:
            self.globals[node.name] = value

    def _exec_if(self, ctx, node):
        for condition, body in node.branches:
            if self._condition(ctx, condition):
                self.exec_block(ctx, body)
                return
        if node.orelse is not None:
            self.exec_block(ctx, node.orelse)

    def _exec_while(self, ctx, node):
        while self._condition(ctx, node.condition):
            try:
                self.exec_block(ctx, node.body)
            except _Break:
                break
            except _Continue:
                pass
            ctx.check()
            ctx.time_slice()  # each test of the condition is computation too

    def _exec_return(self, ctx, node):
        raise _Return(None if node.value is None else self.eval(ctx, node.value))

    def _exec_halt(self, ctx, node):
        # Name the halting thread and line, and the timed-out read that led there if any (URCL's External Control
        # halts when its reverse socket read times out: the client has dropped, or this side read too late).
        after = f", after {ctx.last_timeout}" if ctx.last_timeout else ""
        self._note_end(f"halt in thread {ctx.name} at line {node.line}{after}")
        raise _Halt()

    def _exec_break(self, ctx, node):
        raise _Break()

    def _exec_continue(self, ctx, node):
        raise _Continue()

    def _exec_definition(self, ctx, node):
        """Definitions were hoisted by compile_program: nothing to do when execution passes them."""

    def _exec_kill(self, ctx, node):
        """Kill a thread; a move it was executing is aborted (the arm decelerates, modelling choice)."""
        handle = self._load(ctx, node.handle, node)
        thread = self._threads.get(handle)
        if thread is None:
            return
        thread.request_cancel()
        motion = thread.motion
        if motion is not None and not motion.done:
            try:
                self.controller.stopj(KILLED_MOVE_DECELERATION)
            except CommandRefused:
                pass

    def _exec_join(self, ctx, node):
        handle = self._load(ctx, node.handle, node)
        thread = self._threads.get(handle)
        if thread is None:
            return
        with ctx.waiting():
            while not thread.done.wait(0.05) and not ctx.cancel.is_set():
                pass
        ctx.check()

    def _exec_enter_critical(self, ctx, node):
        ctx.critical += 1

    def _exec_exit_critical(self, ctx, node):
        ctx.critical = max(0, ctx.critical - 1)

    # --- variables
    def _load(self, ctx, name, node):
        if ctx.frames and name in ctx.frames[-1]:
            return ctx.frames[-1][name]
        if name in self.globals:
            return self.globals[name]
        if name in BUILTIN_CONSTANTS:
            return BUILTIN_CONSTANTS[name]
        raise URScriptRuntimeError(node.line, node.column, f"runtime_error_name_not_found:{name}:")

    def _bound(self, ctx, name):
        """Whether `name` is a variable of the running function's frame or a global."""
        return bool(ctx.frames and name in ctx.frames[-1]) or name in self.globals

    def _store(self, ctx, name, value):
        if ctx.frames:
            frame = ctx.frames[-1]
            if name in frame or (name not in self.globals):
                frame[name] = value
                return
        self.globals[name] = value

    def _condition(self, ctx, node):
        try:
            return truth(self.eval(ctx, node))
        except ScriptError as error:
            raise URScriptRuntimeError(node.line, node.column, error.text) from None

    # --- expressions
    def eval(self, ctx: ThreadContext, node: object) -> object:
        """Value of expression `node`."""
        return _EXPRESSIONS[type(node)](self, ctx, node)

    def _eval_literal(self, ctx, node):
        return node.value

    def _eval_name(self, ctx, node):
        return self._load(ctx, node.name, node)

    def _eval_list(self, ctx, node):
        return [self.eval(ctx, item) for item in node.items]

    def _eval_pose(self, ctx, node):
        values = [self.eval(ctx, item) for item in node.items]
        try:
            return Pose(values)
        except ScriptError as error:
            raise URScriptRuntimeError(node.line, node.column, error.text) from None

    def _eval_index(self, ctx, node):
        return _element(self.eval(ctx, node.target), self.eval(ctx, node.index), node)

    def _eval_matrix_index(self, ctx, node):
        row = _element(self.eval(ctx, node.target), self.eval(ctx, node.row_index), node)
        return _element(row, self.eval(ctx, node.column_index), node)

    def _eval_unary(self, ctx, node):
        value = self.eval(ctx, node.operand)
        try:
            if node.op == "not":
                return not truth(value)
            number = require_number(value, node.op)
            return -number if node.op == "-" else number
        except ScriptError as error:
            raise URScriptRuntimeError(node.line, node.column, error.text) from None

    def _eval_binary(self, ctx, node):
        op = node.op
        try:
            if op == "and":
                return truth(self.eval(ctx, node.left)) and truth(self.eval(ctx, node.right))
            if op == "or":
                return truth(self.eval(ctx, node.left)) or truth(self.eval(ctx, node.right))
            left, right = self.eval(ctx, node.left), self.eval(ctx, node.right)
            fast = NUMERIC_FAST_PATH.get(op)
            if fast is not None and type(left) in PLAIN_NUMBERS and type(right) in PLAIN_NUMBERS:
                return fast(left, right)
            return BINARY[op](left, right)
        except ScriptError as error:
            raise URScriptRuntimeError(node.line, node.column, error.text) from None

    def _eval_call(self, ctx, node):
        args = [self.eval(ctx, arg) for arg in node.args]
        kwargs = {name: self.eval(ctx, value) for name, value in node.kwargs}
        function = self.program.functions.get(node.name)
        if function is not None:
            return self._call_function(ctx, function, args, kwargs, node)
        builtin = self.builtins[node.name]
        try:
            return builtin(ctx, *args, **kwargs)
        except ScriptError as error:
            raise URScriptRuntimeError(node.line, node.column, error.text) from None
        except ValueError as error:
            raise URScriptRuntimeError(node.line, node.column, f"runtime_error:{node.name}:{error}:") from None
        except TypeError as error:
            raise URScriptRuntimeError(
                node.line, node.column, f"runtime_error:wrong arguments to {node.name}:{error}:"
            ) from None

    def _call_function(self, ctx: ThreadContext, function: nodes.FunctionDef, args: list[object],
                       kwargs: dict[str, object], node: nodes.Call) -> object:
        if len(ctx.frames) >= MAX_CALL_DEPTH:
            raise URScriptRuntimeError(node.line, node.column, STACK_OVERFLOW)
        frame = self._bind_arguments(ctx, function, args, kwargs, node)
        ctx.frames.append(frame)
        try:
            self.exec_block(ctx, function.body)
        except _Return as result:
            return result.value
        finally:
            ctx.frames.pop()
        return None

    def _bind_arguments(self, ctx, function, args, kwargs, node):
        params = function.params
        if len(args) > len(params):
            raise URScriptRuntimeError(
                node.line, node.column, f"runtime_error:{function.name} takes {len(params)} arguments:"
            )
        frame = {}
        for param, value in zip(params, args):
            frame[param.name] = copy_value(value)
        for name, value in kwargs.items():
            if name in frame or not any(p.name == name for p in params):
                raise URScriptRuntimeError(
                    node.line, node.column, f"runtime_error:{function.name}:bad argument {name}:"
                )
            frame[name] = copy_value(value)
        for param in params:
            if param.name not in frame:
                if param.default is None:
                    raise URScriptRuntimeError(
                        node.line, node.column, f"runtime_error:{function.name}:missing argument {param.name}:"
                    )
                frame[param.name] = copy_value(self.eval(ctx, param.default))
        return frame

    def _eval_run(self, ctx, node):
        definition = self.program.threads[node.thread]
        handle = next(self._handles)
        thread_context = self._new_context(definition.name)
        if ctx.cancel.is_set():
            thread_context.request_cancel()
        self._threads[handle] = thread_context
        python_thread = threading.Thread(
            target=self._run_thread, args=(thread_context, definition), name=f"urscript-{definition.name}", daemon=True
        )
        python_thread.start()
        return handle

    def _run_thread(self, ctx: ThreadContext, definition: nodes.ThreadDef) -> None:
        self._python_threads.add(threading.get_ident())
        self.scheduler.acquire()
        ctx.set_running(True)
        ctx.frames.append({})
        try:
            self.exec_block(ctx, definition.body)
        except _Halt:
            self.cancel()
        except (_Return, _Break, _Continue, Cancelled):
            pass
        except URScriptRuntimeError as error:
            self._record_error(error)
        except Exception as error:  # noqa: BLE001 - whatever fails in a program ends it as a runtime error
            self._record_error(unexpected_error(ctx, error))
        finally:
            self.controller.release_speed_hold(ctx)  # an ended thread sends no next command
            ctx.done.set()
            ctx.set_running(False)
            self.controller.frame_turn.leave(ctx)
            self.scheduler.release()


def unexpected_error(ctx: ThreadContext, error: Exception) -> URScriptRuntimeError:
    """Any other exception of a script thread as a runtime error at the thread's line (RecursionError: overflow)."""
    if isinstance(error, RecursionError):
        return URScriptRuntimeError(ctx.line, 0, STACK_OVERFLOW)
    log.debug("script thread %s failed at line %d", ctx.name, ctx.line, exc_info=error)
    detail = f"{type(error).__name__}: {error}"[:200]
    return URScriptRuntimeError(ctx.line, 0, f"runtime_error:simulator internal error ({detail}):")


def _checked_index(container, index, node):
    """Validated integer index into a list, pose or string (URScriptRuntimeError naming the problem)."""
    if not isinstance(container, (list, str)):
        raise URScriptRuntimeError(node.line, node.column, f"runtime_error:cannot index {to_str(container)}:")
    if isinstance(index, float) and index.is_integer():
        index = int(index)
    if not isinstance(index, int) or isinstance(index, bool):
        raise URScriptRuntimeError(node.line, node.column, f"runtime_error:index must be an integer:{to_str(index)}:")
    if not 0 <= index < len(container):
        raise URScriptRuntimeError(
            node.line, node.column, f"runtime_error:index out of range:{index} not in 0..{len(container) - 1}:"
        )
    return index


def _element(container, index, node):
    return container[_checked_index(container, index, node)]


def _pose_element(value, node):
    """A value stored into a pose: a number, kept as float (URScriptRuntimeError otherwise)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise URScriptRuntimeError(node.line, node.column, "runtime_error:pose element must be a number:")
    return float(value)


_STATEMENTS = {
    nodes.ExprStatement: Execution._exec_expr,
    nodes.Assign: Execution._exec_assign,
    nodes.GlobalDecl: Execution._exec_global,
    nodes.LocalDecl: Execution._exec_local,
    nodes.If: Execution._exec_if,
    nodes.While: Execution._exec_while,
    nodes.Return: Execution._exec_return,
    nodes.Halt: Execution._exec_halt,
    nodes.Break: Execution._exec_break,
    nodes.Continue: Execution._exec_continue,
    nodes.Kill: Execution._exec_kill,
    nodes.Join: Execution._exec_join,
    nodes.EnterCritical: Execution._exec_enter_critical,
    nodes.ExitCritical: Execution._exec_exit_critical,
    nodes.FunctionDef: Execution._exec_definition,
    nodes.ThreadDef: Execution._exec_definition,
    nodes.SecDef: Execution._exec_definition,
}

_EXPRESSIONS = {
    nodes.Literal: Execution._eval_literal,
    nodes.Name: Execution._eval_name,
    nodes.ListExpr: Execution._eval_list,
    nodes.PoseExpr: Execution._eval_pose,
    nodes.Index: Execution._eval_index,
    nodes.MatrixIndex: Execution._eval_matrix_index,
    nodes.Unary: Execution._eval_unary,
    nodes.Binary: Execution._eval_binary,
    nodes.Call: Execution._eval_call,
    nodes.Run: Execution._eval_run,
}
