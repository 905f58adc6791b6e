"""ProgramRunner: the controller's URScript runtime — compile, run, replace, stop, pause and resume programs.

The primary/secondary/realtime servers hand every received script to `submit(source, origin)`.
- A main program (a `def` program or statement lines) replaces the running one, as on the controller.
- A `sec` program runs alongside the main one and does not change the program state; its errors are reported but
  do not stop the main program (the controller's ban on motion and sleep in `sec` programs is not enforced).
- A script that fails to compile is reported (RuntimeExceptionMessage) and does not disturb the running program
  (the real controller's choice here is not documented).
- A main program sent while a protective stop is latched is not run: the refusal is reported as an error-code
  message naming the protective stop and its fix (a controller starts no program until the stop is unlocked).
- Program state goes to the controller (`set_program_state`): runtime_state, robot_status_bits, dashboard and
  primary views all read it. KeyMessages PROGRAM_XXX_STARTED / PROGRAM_XXX_STOPPED carry the program name.
- When a program is stopped, replaced, paused or fails, the arm decelerates to rest (a paused move starts again
  from there on resume); when it ends normally the last commanded motion is left to finish.
"""
import logging
import threading
from collections.abc import Callable, Mapping

from sim_ursim.messages import ErrorCodeMessage, KeyMessage, RuntimeExceptionMessage
from sim_ursim.modes import PROTECTIVE_STOP_REPORT_LEVEL
from sim_ursim.motion_queue import DEFAULT_STOP_CODE
from sim_ursim.urscript.builtins import BUILTINS
from sim_ursim.urscript.interpreter import CompileError, Execution, compile_program
from sim_ursim.urscript.parser import URScriptSyntaxError, parse
from sim_ursim.vocabulary import PROTECTIVE_STOP_DECELERATION, CommandRefused, SafetyMode

log = logging.getLogger("sim_ursim.urscript")

PAUSE_DECELERATION = 4.0  # rad/s²: a paused program's arm comes to rest smoothly (its move resumes on `resume`)
JOIN_TIMEOUT = 2.0  # s: a cancelled program's threads end at their next statement or wait, far sooner than this


class _Running:
    """A started Execution and the Python thread running its main thread."""

    def __init__(self, execution, thread=None):
        self.execution = execution
        self.thread = thread


class ProgramRunner:
    """Runs URScript programs on `controller` (attach with controller.attach_program_runner(runner))."""

    def __init__(self, controller, builtins: Mapping[str, Callable] | None = None):
        self._controller = controller
        self._builtins = BUILTINS if builtins is None else builtins
        self._lock = threading.RLock()
        self._submit_lock = threading.Lock()  # one replacement at a time
        self._main: _Running | None = None
        self._secondary: list[_Running] = []
        self._paused = False

    # ----------------------------------------------------------------------------------------------- queries
    @property
    def is_running(self) -> bool:
        """True while a main program runs (paused included)."""
        with self._lock:
            return self._main is not None

    @property
    def is_paused(self) -> bool:
        """True while the main program is paused."""
        with self._lock:
            return self._main is not None and self._paused

    @property
    def program_name(self) -> str | None:
        """Name of the running main program (None when idle)."""
        with self._lock:
            return None if self._main is None else self._main.execution.program.name

    def wait_until_stopped(self, timeout: float | None) -> bool:
        """Block until no main program runs (True) or `timeout` s pass (False)."""
        with self._lock:
            running = self._main
        if running is None:
            return True
        running.thread.join(timeout)
        return not running.thread.is_alive()

    # ----------------------------------------------------------------------------------------------- commands
    def submit(self, source: str, origin: str = "unknown") -> bool:
        """Compile and start `source`; returns True if it started, False if it was refused (error published)."""
        try:
            program = compile_program(parse(source), self._builtins)
        except (URScriptSyntaxError, CompileError) as error:
            log.info("script from %s refused: %s", origin, error)
            self._publish(RuntimeExceptionMessage(line=error.line, column=error.column, text=error.text))
            return False
        if program.secondary:
            self._start_secondary(Execution(program, self._controller, self._builtins))
            return True
        if self._controller.state().safety_mode == SafetyMode.PROTECTIVE_STOP:
            self._refuse_during_protective_stop(program.name, origin)
            return False
        execution = Execution(program, self._controller, self._builtins)   # its main thread starts below
        with self._submit_lock:
            with self._lock:
                previous = self._detach_main()
            self._end(previous)
            with self._lock:
                running = _Running(execution)
                running.thread = threading.Thread(target=self._run_main, args=(running,), daemon=True,
                                                  name=f"urscript-{program.name}")
                self._main = running
                self._controller.set_program_state(True, False)
                running.thread.start()
        log.info("program %s started from %s", program.name, origin)
        return True

    def stop(self) -> None:
        """Stop the main program (and secondary programs); returns once its threads have ended."""
        with self._lock:
            previous = self._detach_main()
            for running in self._secondary:
                running.execution.cancel()
        self._end(previous)
        if previous is not None:
            self._controller.set_program_state(False)

    def pause(self) -> None:
        """Pause the main program at its next statement; the arm decelerates and the interrupted move is
        commanded again on resume."""
        with self._lock:
            if self._main is None:
                return
            self._paused = True
            self._main.execution.unpaused.clear()
            self._controller.set_program_state(True, True)
        self._stop_arm(PAUSE_DECELERATION)

    def resume(self) -> None:
        """Resume a paused main program."""
        with self._lock:
            if self._main is None:
                return
            self._paused = False
            self._main.execution.unpaused.set()
            self._controller.set_program_state(True, False)

    # ----------------------------------------------------------------------------------------------- internals
    def _detach_main(self):
        """Take the running main program out of the runner (call with the lock held); it still has to be ended."""
        running, self._main = self._main, None
        self._paused = False
        return running

    def _end(self, running):
        """Cancel a detached program, wait for it (unless called from one of its own threads), stop the arm."""
        if running is None:
            return
        running.execution.cancel()
        if not running.execution.owns_current_thread():
            running.thread.join(JOIN_TIMEOUT)
            if running.thread.is_alive():
                log.warning("program %s did not stop within %.1f s", running.execution.program.name, JOIN_TIMEOUT)
        self._stop_arm()

    def _run_main(self, running: "_Running") -> None:
        execution = running.execution
        name = execution.program.name
        try:
            self._publish(KeyMessage(code=0, argument=0, title="PROGRAM_XXX_STARTED", text=name))
            error = execution.run()
            if execution.holds_freedrive:   # a program's freedrive ends with it, as on a controller
                self._controller.set_freedrive(False)
            log.info("program %s ended: %s", name, execution.end_reason)
            if error is not None:
                self._publish(RuntimeExceptionMessage(line=error.line, column=error.column, text=error.text))
                self._stop_arm()
        finally:  # whatever happened, the program is over: the controller never stays PLAYING
            with self._lock:
                if self._main is running:
                    self._main = None
                    self._paused = False
                    self._controller.set_program_state(False)
            self._publish(KeyMessage(code=0, argument=0, title="PROGRAM_XXX_STOPPED", text=name))

    def _start_secondary(self, execution):
        thread = threading.Thread(target=self._run_secondary, args=(execution,), daemon=True,
                                  name=f"urscript-sec-{execution.program.name}")
        with self._lock:
            self._secondary.append(_Running(execution, thread))
        thread.start()

    def _run_secondary(self, execution):
        error = execution.run()
        if execution.holds_freedrive:   # a program's freedrive ends with it, as on a controller
            self._controller.set_freedrive(False)
        if error is not None:
            self._publish(RuntimeExceptionMessage(line=error.line, column=error.column, text=error.text))
        with self._lock:
            self._secondary = [r for r in self._secondary if r.execution is not execution]

    def _stop_arm(self, deceleration=PROTECTIVE_STOP_DECELERATION):
        """Bring the arm to rest as the controller does when a program stops or pauses (nothing to do if it cannot
        move)."""
        if not self._controller.state().motion_active:
            return
        try:
            self._controller.stopj(deceleration)
        except CommandRefused:
            pass

    def _refuse_during_protective_stop(self, name: str, origin: str) -> None:
        """A controller starts no program while a protective stop is latched: the program is not run, the running
        state is left as it is (stopped), and the refusal is reported on the primary/secondary interfaces."""
        log.warning("program %s from %s not started: protective stop", name, origin)
        # The simulator's protective-stop code at its report level (docs/ursim.md: no source found gives the code a
        # controller uses for this refusal).
        self._publish(ErrorCodeMessage(code=DEFAULT_STOP_CODE[0], argument=DEFAULT_STOP_CODE[1],
                                       report_level=PROTECTIVE_STOP_REPORT_LEVEL, data_type=0, data=0,
                                       text=f"Program {name} not started: the robot is in a protective stop; "
                                            "unlock the protective stop first"))

    def _publish(self, message):
        self._controller.messages.publish(message)
