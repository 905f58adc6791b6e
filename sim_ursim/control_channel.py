"""The simulator's fault-control channel: a loopback TCP port (29998) taking one JSON request per line.

Request  {"command": "protective-stop", "reason": "..."} | {"command": "emergency-stop"} |
         {"command": "release-emergency-stop"} | {"command": "drop-connections"} |
         {"command": "freeze", "seconds": 2} | {"command": "latency", "seconds": 0.05} | {"command": "reset"} |
         {"command": "freedrive", "on": true} | {"command": "move-by-hand", "q": [6 floats]} |
         {"command": "set-digital-input", "pin": 0..7, "on": true} | {"command": "speed-slider", "fraction": 0..1} |
         {"command": "status"} | {"command": "shutdown"}
Reply    {"ok": true, "message": "..."} or {"ok": false, "error": "..."}; one line of JSON each. `status` also
         answers "state": {"robot_mode", "safety_mode" (names), "program_running", "freedrive", "q" (6 rad),
         "digital_output_bits" (0-7 standard, 8-15 configurable, 16-17 tool), "time" (the controller's clock, s)}
         for programs.
This port is not a UR interface: it exists so tests and `python -m sim_ursim fault ...` can inject faults.
"""
import json
import logging
import socket

from .tcp_server import Connection, TCPServer
from .vocabulary import CommandRefused, RobotMode, SafetyMode

log = logging.getLogger("sim_ursim.control")

CONTROL_PORT = 29998
MAX_REQUEST_BYTES = 64 * 1024  # one JSON request line; the longest real request (move-by-hand) is ~200 bytes
SEND_TIMEOUT = 2.0  # s a client may leave a reply unread before it is disconnected
FAULT_COMMANDS = ("protective-stop", "emergency-stop", "release-emergency-stop", "drop-connections", "freeze",
                  "latency", "reset", "status", "shutdown")
COMMANDS = FAULT_COMMANDS + ("freedrive", "move-by-hand", "set-digital-input", "speed-slider")


def encode_request(command: str, **arguments) -> bytes:
    """The request line for `command` with its arguments."""
    return (json.dumps({"command": command, **arguments}) + "\n").encode("utf-8")


def execute(request: dict, controller, can_shut_down: bool = False) -> dict:
    """Carry out one decoded request on `controller`; returns the reply dict (errors reported, never raised).

    `shutdown` is only answered here; the server stops the simulator after sending the reply.
    """
    if not isinstance(request, dict) or request.get("command") not in COMMANDS:
        command = request.get("command") if isinstance(request, dict) else request
        return {"ok": False, "error": f"unknown command {command!r}; expected one of {', '.join(COMMANDS)}"}
    command = request["command"]
    if command == "status":  # one snapshot, as a line for people and as fields for programs
        state = controller.state()
        return {"ok": True, "message": status_line(state, controller.faults), "state": status_fields(state)}
    try:
        message = _run(command, request, controller, can_shut_down)
    except (ValueError, CommandRefused, TypeError) as error:
        return {"ok": False, "error": f"{command}: {error}"}
    log.info("control channel: %s -> %s", command, message)
    return {"ok": True, "message": message}


def _argument(request, name):
    """The request's `name` argument; ValueError naming it when missing."""
    if name not in request:
        raise ValueError(f"needs the argument {name!r}")
    return request[name]


def _run(command, request, controller, can_shut_down):
    faults = controller.faults
    if command == "protective-stop":
        controller.protective_stop(request.get("reason", "injected fault"))
        return "protective stop"
    if command == "emergency-stop":
        controller.emergency_stop()
        return "emergency stop pressed"
    if command == "release-emergency-stop":
        controller.release_emergency_stop()
        return "emergency stop released"
    if command == "drop-connections":
        return f"connections dropped (generation {faults.drop_connections()})"
    if command == "freeze":
        seconds = _argument(request, "seconds")
        faults.freeze_streams(seconds)
        return f"streams frozen for {float(seconds)} s"
    if command == "latency":
        seconds = _argument(request, "seconds")
        faults.add_latency(seconds)
        return f"latency {float(seconds)} s"
    if command == "reset":
        faults.reset()
        return "transport faults cleared"
    if command == "freedrive":
        controller.set_freedrive(bool(request.get("on", True)))
        return f"freedrive {'on' if request.get('on', True) else 'off'}"
    if command == "move-by-hand":
        controller.move_joints_by_hand(_argument(request, "q"))
        return "joints moved by hand"
    if command == "set-digital-input":  # simulated wiring: what a sensor on a standard input would do
        pin, on = _argument(request, "pin"), bool(_argument(request, "on"))
        controller.io.set_standard_digital_in(pin, on)
        return f"standard digital input {pin} {'on' if on else 'off'}"
    if command == "speed-slider":  # the operator's slider on the pendant
        fraction = float(_argument(request, "fraction"))
        controller.set_speed_slider(fraction)
        return f"speed slider {fraction:g}"
    if not can_shut_down:
        raise CommandRefused("this channel cannot shut the simulator down")
    return "shutting down"


def status_line(state, faults):
    """One human-readable line: modes, joints and transport faults."""
    joints = " ".join(f"{value:+.4f}" for value in state.actual_q)
    return (f"robot {RobotMode.NAMES[state.robot_mode]}, safety {SafetyMode.NAMES[state.safety_mode]}, "
            f"program {'running' if state.program_running else 'stopped'}, q [{joints}], {faults.describe()}")


def status_fields(state) -> dict:
    """The modes (names), whether a program runs, whether freedrive is on, the joints (6 rad), the digital
    outputs (bits 0-7 standard, 8-15 configurable, 16-17 tool) and the controller's time (s since it started, in
    whole control cycles: RTDE's `timestamp`) of a controller snapshot."""
    return {"robot_mode": RobotMode.NAMES[state.robot_mode], "safety_mode": SafetyMode.NAMES[state.safety_mode],
            "program_running": bool(state.program_running), "freedrive": bool(state.freedrive),
            "q": [float(value) for value in state.actual_q], "digital_output_bits": int(state.digital_output_bits),
            "time": float(state.timestamp)}


def send_request(host: str, command: str, port: int = CONTROL_PORT, timeout: float = 5.0, **arguments) -> dict:
    """Client side: send one request to a simulator's control channel and return its reply dict."""
    with socket.create_connection((host, port), timeout=timeout) as connection:
        connection.sendall(encode_request(command, **arguments))
        reader = connection.makefile("rb")
        line = reader.readline()
    if not line:
        raise ConnectionError(f"the control channel on {host}:{port} closed without replying")
    return json.loads(line)


class ControlChannelServer(TCPServer):
    """Serves the control channel for one Simulator (its controller and its stop request). Exempt from the fault
    channel's drop generations: it is how faults are injected and cleared."""

    follows_faults = False

    def __init__(self, simulator, host, port=CONTROL_PORT):
        super().__init__(simulator.controller, host, port)
        self.simulator = simulator

    def serve(self, connection: Connection) -> None:
        buffered = b""
        for chunk in self.read_chunks(connection):
            buffered += chunk
            while b"\n" in buffered:
                line, buffered = buffered.split(b"\n", 1)
                if not self._reply(connection, line):
                    return
            if len(buffered) > MAX_REQUEST_BYTES:
                # Bounded: an over-long request is answered with an error and the client dropped.
                log.warning("control channel: %s sent an over-long request; closing", connection)
                self._send(connection, {"ok": False,
                                        "error": f"request longer than {MAX_REQUEST_BYTES} bytes: connection closed"})
                return

    def _reply(self, connection: Connection, line: bytes) -> bool:
        """Execute one request line and answer it; False when the connection is over."""
        try:
            request = json.loads(line)
        except ValueError:
            reply = {"ok": False, "error": "request is not one line of JSON"}
        else:
            reply = execute(request, self.simulator.controller, can_shut_down=True)
        if not self._send(connection, reply):
            return False
        if reply["ok"] and request.get("command") == "shutdown":
            self.simulator.request_stop()
        return True

    @staticmethod
    def _send(connection: Connection, reply: dict) -> bool:
        return connection.send_all((json.dumps(reply) + "\n").encode("utf-8"), SEND_TIMEOUT)
