"""`ur3dq serve`'s web server: one page (static files inside the package), a WebSocket per open page, GET /healthz.

Starlette routes served by uvicorn. The page talks JSON over its WebSocket: the server sends `hello`, `scene`,
`program`, `check`, the live `state` (STATE_RATE a second), `confirm` questions and `reply`s; the page sends
`beat` (its heartbeat, every 50 ms), `units`, `take_control` and `cmd` (a button). Commands run in worker threads
(ur3dq.screen.operations); only the page holding control may give them, except Stop and Pause (any open page, as
the pendant's stop button) and the read-only ones (ANY_PAGE). Every motion stops when the controlling page closes or
its heartbeat goes silent for JOG_SILENCE (a jog), freedrive ends when the page that turned it on closes or loses
control, and the controller stops a motion by itself when this server dies (the driver's heartbeat). A question
(`confirm`) about the program is withdrawn when the program changes before it is answered. Log lines name the page
that acted.
"""
from __future__ import annotations

import asyncio
import contextlib
import contextvars
import dataclasses
import functools
import json
import secrets
import sys
import time
import traceback
from collections.abc import AsyncIterator, Callable, Coroutine
from pathlib import Path
from typing import TYPE_CHECKING, Any

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, PlainTextResponse, Response
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.websockets import WebSocket, WebSocketDisconnect

from ur3dq import units as u
from ur3dq.errors import UR3DQError
from ur3dq.robot import jog_steps
from ur3dq.screen import scene, views
from ur3dq.screen.access import request_allowed, token_accepted
from ur3dq.screen.editing import program_text
from ur3dq.screen.operations import MAX_LOOPS, Operations, output_pin
from ur3dq.screen.pages import Page, Pages
from ur3dq.screen.station import Station, StationConfig

if TYPE_CHECKING:
    from ur3dq.program.steps import Step
    from ur3dq.robot.robot import Robot

STATIC = Path(__file__).parent / "static"
JOG_SILENCE = 0.25      # s without the controlling page's heartbeat that stop a jog (the controller's own at 0.25 s)
WATCH_PERIOD = 0.05     # s between the server's checks of that silence
JOG_STEPS = (None, *jog_steps.STEP_SIZES)     # mm or degrees (the keyboard jog's); None: as far as held
# Commands every open page may give: stopping the arm is never refused (as the pendant's stop button), and these
# others read or propose only.
ANY_PAGE = ("stop", "pause", "check", "default_name")
RUNS = ("run", "move_here")   # the questions whose outcome a page opened later still shows
# The page whose message is being handled (a context variable: worker threads started by asyncio.to_thread see it).
_acting: contextvars.ContextVar[Page | None] = contextvars.ContextVar("acting", default=None)


@dataclasses.dataclass(frozen=True)
class Question:
    """An open `confirm`: the page asked, the command, what a yes does and the program's text when it was asked
    (None: a question about no program, an output switch)."""

    page: Page
    cmd: str
    action: Callable[[], str]
    program: str | None


@dataclasses.dataclass(frozen=True)
class ServeConfig:
    """The station (robot, store, cell) and where to listen: `bind` address, `port`, `token` (required off
    loopback)."""

    station: StationConfig
    bind: str = "127.0.0.1"
    port: int = 8765
    token: str | None = None
    units: u.Units = u.Units()


def one_line(error: BaseException) -> str:
    """The error as the command line prints it: its message and notes on one line."""
    text = str(error) or type(error).__name__
    return " ".join(" ".join([text, *(getattr(error, "__notes__", None) or [])]).split())


class ScreenServer:
    """The application: Station + Operations + Pages, and the Starlette app serving them."""

    def __init__(self, config: ServeConfig, log: Callable[[str], None] | None = None):
        self.config = config
        self.pages = Pages()
        self._log_line = log or (lambda line: print(line, file=sys.stderr, flush=True))
        self.station = Station(config.station, self._on_state, self._on_program, prepare=self._prepare)
        self.ops = Operations(self.station, self._log)
        self._questions: dict[str, Question] = {}
        self._freedrive_by: Page | None = None    # the page that turned freedrive on (it ends when that page goes)
        self._last_run: dict[str, Any] | None = None   # the last run's (or move's) outcome, for pages opened later
        self._loop: asyncio.AbstractEventLoop | None = None
        self._scene_of: object = None   # the robot whose arm the pages were last sent
        self.app = Starlette(routes=[
            Route("/", self.index), Route("/healthz", self.healthz),
            WebSocketRoute("/ws", self.websocket), Mount("/static", StaticFiles(directory=STATIC), name="static"),
        ], lifespan=self._lifespan)

    # ------------------------------------------------------------------------------------------------ lifespan
    @contextlib.asynccontextmanager
    async def _lifespan(self, app: Starlette) -> AsyncIterator[None]:
        self._loop = asyncio.get_running_loop()
        self.station.start()
        watch = asyncio.create_task(self._watch_silence())
        try:
            yield
        finally:
            watch.cancel()
            if self.station.activity is not None and self.station.robot is not None:
                with contextlib.suppress(UR3DQError, OSError):
                    await asyncio.to_thread(self.ops.stop)
            await asyncio.to_thread(self.station.close)

    def _log(self, line: str) -> None:
        """Log `line` under the page that acted (the one whose message is being handled), else 'server'."""
        acting = _acting.get()
        self._log_line(f"{time.strftime('%H:%M:%S')} [{acting.id if acting else 'server'}] {line}")

    # ------------------------------------------------------------------------------------------------ HTTP
    def _token_ok(self, given: str | None) -> bool:
        return token_accepted(self.config.token, given)

    async def index(self, request: Request) -> Response:
        if not request_allowed(request.headers.get("host"), None, self.config.token is not None):
            return PlainTextResponse("this screen answers only on this machine's own address", 403)
        if not self._token_ok(request.query_params.get("token")):
            return PlainTextResponse("this screen needs its token: open the URL `ur3dq serve` printed", 401)
        return FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-store"})

    async def healthz(self, request: Request) -> Response:
        latest = self.station.latest
        return JSONResponse({"robot": latest.robot_mode, "program": latest.program})

    # ------------------------------------------------------------------------------------------------ from threads
    def _on_state(self, snapshot: views.Snapshot) -> None:
        if self._loop is None:
            return
        if snapshot.connected and self._scene_of is not self.station.robot:
            self._scene_of = self.station.robot
            self.pages.broadcast(lambda page: self._scene())
        for page in self.pages.all():
            page.post_state(json.dumps(views.state_message(snapshot, page.units, self.pages.control_of(page))))

    def _on_program(self, steps: list[Step]) -> None:
        frames = scene.pose_frames(steps)
        for page in self.pages.all():
            self._post_program(page, steps, frames)
        if self._loop is not None and any(q.program is not None for q in tuple(self._questions.values())):
            text = program_text(steps) if self.station.store_error is None else None
            self._loop.call_soon_threadsafe(self._withdraw_stale, text)

    def _withdraw_stale(self, program: str | None) -> None:
        """Withdraw the open question about a program other than `program` (None: the store does not read)."""
        for qid, question in list(self._questions.items()):
            if question.program is not None and question.program != program:
                del self._questions[qid]
                why = (f"the program changed while the question ({question.cmd}) was open: nothing done; look at "
                       "the program and ask again")
                question.page.post({"type": "withdrawn", "qid": qid})
                question.page.post({"type": "reply", "id": None, "cmd": question.cmd, "ok": False, "error": why})
                self._log(f"question withdrawn: {why}")

    def _post_program(self, page: Page, steps: list[Step], frames: list[dict[str, Any]] | None = None) -> None:
        source = self.station.store_error or str(self.station.store.path)
        page.post(views.program_message(steps, page.units, self.ops.editor.state(),
                                        scene.pose_frames(steps) if frames is None else frames, source,
                                        self.ops.store_problem()))

    def _spawn(self, coroutine: Coroutine[Any, Any, None]) -> None:
        asyncio.ensure_future(coroutine)

    def _prepare(self, robot: Robot) -> None:
        self.ops.warm_up(robot)
        self._log(f"connected to {robot.host} ({robot.model_name}); ready")

    def _scene(self) -> dict[str, Any]:
        shape = self.station.shape
        return {"type": "scene", "arm": None if shape is None else shape.description(),
                "cell": scene.cell_description(self.station.config.cell)}

    # ------------------------------------------------------------------------------------------------ WebSocket
    async def websocket(self, websocket: WebSocket) -> None:
        allowed = request_allowed(websocket.headers.get("host"), websocket.headers.get("origin"),
                                  self.config.token is not None)
        if not (allowed and self._token_ok(websocket.query_params.get("token"))):
            await websocket.close(code=4403)
            return
        await websocket.accept()
        client = websocket.client
        page = Page(f"{client.host}:{client.port}" if client else "?", asyncio.get_running_loop(),
                    self.config.units)
        self.pages.join(page)
        _acting.set(page)
        self._log(f"{page.label} opened the screen" + (" and has control" if self.pages.holder is page else ""))
        sender = asyncio.create_task(self._send_loop(websocket, page))
        try:
            page.post(self._hello(page))
            page.post(self._scene())
            self._post_program(page, self.station.steps)
            if self.ops.last_check is not None:
                page.post(views.check_for_page(self.ops.last_check, page.units))
            if self._last_run is not None:
                page.post(self._last_run)
            while True:
                message = json.loads(await websocket.receive_text())
                await self._receive(page, message)
        except (WebSocketDisconnect, json.JSONDecodeError, RuntimeError):
            pass
        finally:
            sender.cancel()
            await self._page_left(page)

    async def _send_loop(self, websocket: WebSocket, page: Page) -> None:
        with contextlib.suppress(WebSocketDisconnect, RuntimeError, OSError):
            while True:
                for text in await page.next_texts():
                    await websocket.send_text(text)

    async def _page_left(self, page: Page) -> None:
        had_control = self.pages.leave(page)
        self._log(f"{page.label} closed the screen")
        if had_control and self.station.activity is not None:
            self._log(f"the controlling page closed during {self.station.activity}: stopping the arm")
            with contextlib.suppress(UR3DQError, OSError):
                if self.station.activity.startswith("jog"):
                    await asyncio.to_thread(self.ops.jog_stop, "the page closed")
                else:
                    await asyncio.to_thread(self.ops.stop, f"stopped: the page that had control ({page.id}) closed")
        await self._end_freedrive_of(page, "closed")

    async def _end_freedrive_of(self, page: Page, why: str) -> None:
        """End freedrive if `page` turned it on (it closed or lost control: nobody is there to turn it off)."""
        if self._freedrive_by is not page:
            return
        self._freedrive_by = None
        self._log(f"the page that turned freedrive on {why}: ending freedrive")
        try:
            await asyncio.to_thread(self.ops.freedrive, False)
        except (UR3DQError, OSError) as error:
            self._log(f"Error (freedrive off): {one_line(error)}")

    def _hello(self, page: Page) -> dict[str, Any]:
        config = self.config.station
        return {"type": "hello", "page": page.id, "host": config.host, "store": str(config.store_path),
                "cell": str(config.cell_path) if config.cell_path else None,
                "units": {"angle": page.units.angle, "length": page.units.length}, **self._jog_choices(page.units)}

    @staticmethod
    def _jog_choices(units: u.Units) -> dict[str, Any]:
        """The jog panel's step choices (labels in `units`) and its speed range."""
        steps = [jog_steps.step_of("J1", 1, size) for size in JOG_STEPS[1:]]
        linear = [jog_steps.step_of("X", 1, size) for size in JOG_STEPS[1:]]
        return {"joint_steps": ["continuous"] + [u.show(step.distance, u.ANGLE, units) for step in steps],
                "linear_steps": ["continuous"] + [u.show(step.distance, u.LENGTH, units) for step in linear],
                "max_joint_speed": u.show(jog_steps.MAX_JOINT_SPEED, u.ANGULAR_SPEED, units),
                "max_tcp_speed": u.show(jog_steps.MAX_TCP_SPEED, u.LINEAR_SPEED, units)}

    async def _watch_silence(self) -> None:
        """Stop a jog whose controlling page's heartbeat has gone silent for JOG_SILENCE. After this loop itself
        was held up that long (the beats that came meanwhile wait unread) the silence is counted again: the
        controller's own watchdog on the keep-alive still stops a jog whose beats really stopped."""
        woke = time.monotonic()
        while True:
            await asyncio.sleep(WATCH_PERIOD)
            now, before = time.monotonic(), woke
            woke = now
            if now - before > JOG_SILENCE:
                continue
            activity, holder = self.station.activity, self.pages.holder
            if activity and activity.startswith("jog"):
                silent = holder is None or time.monotonic() - holder.last_beat > JOG_SILENCE
                if silent:
                    with contextlib.suppress(UR3DQError, OSError):
                        await asyncio.to_thread(self.ops.jog_stop, "the page's heartbeat went silent")

    # ------------------------------------------------------------------------------------------------ messages
    async def _receive(self, page: Page, message: dict[str, Any]) -> None:
        kind = message.get("type")
        if kind == "beat":
            page.last_beat = time.monotonic()
            if self.pages.holder is page and (self.station.activity or "").startswith("jog"):
                with contextlib.suppress(UR3DQError, OSError):
                    await asyncio.to_thread(self.ops.keep_alive)
        elif kind == "units":
            self._set_units(page, message)
        elif kind == "take_control":
            previous = self.pages.take_control(page)
            self._log(f"{page.label} took control" + (f" from {previous.label}" if previous else ""))
            if previous is not None and (self.station.activity or "").startswith("jog"):
                await asyncio.to_thread(self.ops.jog_stop, "control was taken over")
            if previous is not None:
                await self._end_freedrive_of(previous, "lost control")
        elif kind == "cmd":
            self._spawn(self._command(page, str(message.get("cmd")), message.get("args") or {}, message.get("id")))

    def _set_units(self, page: Page, message: dict[str, Any]) -> None:
        try:
            page.units = u.Units(angle=str(message.get("angle")), length=str(message.get("length")))
        except ValueError as error:
            page.post({"type": "reply", "ok": False, "error": one_line(error)})
            return
        page.post(self._hello(page))
        self._post_program(page, self.station.steps)
        if self.ops.last_check is not None:
            page.post(views.check_for_page(self.ops.last_check, page.units))

    async def _command(self, page: Page, name: str, args: dict[str, Any], reply_id: object) -> None:
        reply = {"type": "reply", "id": reply_id, "cmd": name}
        _acting.set(page)
        try:
            if self.pages.holder is not page and name not in ANY_PAGE:
                holder = self.pages.holder
                raise PermissionError("this page is read-only: " + (f"{holder.label} has control; take control "
                                                                    "first" if holder else "take control first"))
            text = await self._run_command(page, name, args)
            reply.update(ok=True, text=text)
        except (UR3DQError, ValueError, OSError, PermissionError) as error:
            if isinstance(error, UR3DQError):   # its values (a path check's, a reach's) in this page's units
                error.shown_in(page.units)
            reply.update(ok=False, error=views.error_text(one_line(error)))   # its hints point at the buttons
            if name not in ("jog", "jog_stop"):
                self._log(f"Error ({name}): {one_line(error)}")
        except Exception as error:   # a bug: one line for the page, the traceback in the server's log
            traceback.print_exc(file=sys.stderr)
            reply.update(ok=False, error=f"internal error ({type(error).__name__}): {one_line(error)}")
        page.post(reply)

    async def _run_command(self, page: Page, name: str, args: dict[str, Any]) -> str:
        ops, units = self.ops, page.units
        if name == "answer":
            return await self._answer(page, str(args.get("qid")), bool(args.get("yes")))
        if name == "jog":   # press and release are noted here, in the order the page sent them
            pressed = ops.press()
            return await asyncio.to_thread(ops.jog_start, *self._jog_request(args), units, pressed)
        if name == "jog_stop":
            ops.release()
            await asyncio.to_thread(ops.jog_stop)
            return "stopped"
        if name == "check":
            result = await asyncio.to_thread(ops.check, args.get("from"))
            self.pages.broadcast(lambda other: views.check_for_page(result, other.units))
            shown = views.check_for_page(result, units)
            line: str = shown["problems"][0]["line"] if shown["problems"] else result["summary"]
            return line
        if name in ("run", "move_here", "retouch", "output"):
            return await self._ask(page, name, args)
        simple = {
            "power_on": ops.power_on, "power_off": ops.power_off, "brake_release": ops.brake_release,
            "unlock": ops.unlock, "pause": ops.pause, "resume": ops.resume, "undo": ops.undo,
            "stop": lambda: ops.stop(f"stopped by the operator (Stop on {page.id})"),
            "redo": ops.redo, "default_name": ops.default_pose_name,
            "freedrive": lambda: self._freedrive(page, bool(args.get("on"))),
            "speed": lambda: ops.set_speed_slider(float(args.get("fraction", -1))),
            "record": lambda: ops.record(str(args.get("name", "")).strip() or ops.default_pose_name(),
                                         args.get("after")),
            "edit": lambda: ops.edit(str(args.get("kind")), dict(args.get("fields") or {}), units),
        }
        if name not in simple:
            raise ValueError(f"unknown command {name!r}")
        return await asyncio.to_thread(simple[name])

    def _freedrive(self, page: Page, on: bool) -> str:
        """Freedrive on or off (in a worker thread); `page` turned it on: it ends when that page goes."""
        done = self.ops.freedrive(on)
        self._freedrive_by = page if on else None
        return done

    @staticmethod
    def _jog_request(args: dict[str, Any]) -> tuple[jog_steps.JogStep, float]:
        """(JogStep, speed) of a jog button: the axis, direction, frame, the step choice (an index of JOG_STEPS)
        and the speed as a fraction of the jog's top speed."""
        fraction = float(args.get("speed", 0.1))
        if not 0.01 <= fraction <= 1.0:
            raise ValueError(f"jog speed: {fraction!r} is not a fraction 0.01..1 of the jog's top speed")
        index = int(args.get("step", 0))
        if not 0 <= index < len(JOG_STEPS):
            raise ValueError(f"jog step: {index!r} is not one of the {len(JOG_STEPS)} choices")
        step = jog_steps.step_of(str(args.get("axis", "")), 1 if int(args.get("direction", 1)) > 0 else -1,
                                 JOG_STEPS[index], str(args.get("frame", "base")))
        return step, step.top_speed * fraction

    async def _ask(self, page: Page, name: str, args: dict[str, Any]) -> str:
        """Prepare a motion (or output switch) that needs the operator's yes; post the question to the page. The
        program's text is kept with a question about it: a change before the answer withdraws the question."""
        ops = self.ops
        question: str | None
        action: Callable[[], str]
        program = program_text(ops.program()) if name in ("run", "move_here", "retouch") else None
        if name == "run":
            loops = u.whole_number(args.get("loops", 1), "loops", 1, MAX_LOOPS)
            try:
                question, action = await asyncio.to_thread(ops.prepare_run, args.get("from"), loops)
            finally:
                checked = ops.last_check
                if checked is not None:
                    self.pages.broadcast(lambda other: views.check_for_page(checked, other.units))
        elif name == "move_here":
            question, action = await asyncio.to_thread(ops.prepare_move_here, str(args.get("name")), page.units)
        elif name == "retouch":
            step = str(args.get("name"))
            question, action = f"Re-record {step!r} at the arm's current pose?", lambda: ops.retouch(step)
        else:
            group, pin = output_pin(args.get("group"), args.get("pin"))
            on = bool(args.get("on"))
            question = ops.output_question(group, pin, on)
            if question is None:
                return await asyncio.to_thread(ops.set_output, group, pin, on)
            action = functools.partial(ops.set_output, group, pin, on)
        qid = secrets.token_hex(6)
        self._questions = {qid: Question(page, name, action, program)}   # only the newest question can be answered
        page.post({"type": "confirm", "qid": qid, "question": question, "cmd": name})
        return "asked"

    async def _answer(self, page: Page, qid: str, yes: bool) -> str:
        """Do what the question `qid` asked once answered yes, if it is still open and its program is still the
        store's (read again now: a change made a moment ago is seen); note a run's outcome for every page."""
        asked = self._questions.pop(qid, None)
        if asked is None or asked.page is not page:
            raise ValueError("that question is no longer open: ask again")
        if not yes:
            self._log("answered no: nothing done.")
            return "answered no: nothing done."
        if asked.program is not None:
            await asyncio.to_thread(self.station.reload_program)
            if program_text(self.ops.program()) != asked.program:
                raise ValueError("the program changed since the question was asked: nothing done; ask again")
        if asked.cmd not in RUNS:
            return await asyncio.to_thread(asked.action)
        try:
            done = await asyncio.to_thread(asked.action)
        except (UR3DQError, OSError) as error:
            self._note_run({"ok": False, "error": f"the last {asked.cmd.replace('_', ' ')}: {one_line(error)}"})
            raise
        self._note_run({"ok": True, "text": f"the last {asked.cmd.replace('_', ' ')}: {done}"})
        return done

    def _note_run(self, outcome: dict[str, Any]) -> None:
        """Keep a run's outcome for the pages opened later (a reload mid-run shows how it ended) and show it on the
        other open pages (the one that answered gets its reply)."""
        self._last_run = {"type": "reply", "id": None, "cmd": "last_run", **outcome}
        acting = _acting.get()
        for other in self.pages.all():
            if other is not acting:
                other.post(self._last_run)
