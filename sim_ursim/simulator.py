"""One simulated robot on one loopback address: controller + URScript runner + every server + the fault channel."""
import logging
import threading

from .control_channel import CONTROL_PORT, ControlChannelServer
from .controller import Controller
from .dashboard.protocol import pendant_settings
from .dashboard.server import DashboardServer
from .polyscope.external_control import DEFAULT_PORT as EXTERNAL_CONTROL_PORT
from .polyscope.external_control import ExternalControlSettings
from .polyscope.program_tab import ProgramTab
from .primary.server import PrimaryServer, RealtimeServer, SecondaryServer
from .rtde.server import RTDEServer
from .urscript.runtime import ProgramRunner

log = logging.getLogger("sim_ursim")

DASHBOARD_PORT, PRIMARY_PORT, SECONDARY_PORT, REALTIME_PORT, RTDE_PORT = 29999, 30001, 30002, 30003, 30004
STANDARD_PORTS = (DASHBOARD_PORT, PRIMARY_PORT, SECONDARY_PORT, REALTIME_PORT, RTDE_PORT, CONTROL_PORT)


class Simulator:
    """Controller and servers of one emulated robot bound on `host` (the robot's standard ports)."""

    def __init__(self, model="ur3", version=None, host="127.0.0.1", initial_q=None, calibration=None,
                 frequency=None, programs_directory=None, external_control_host=None,
                 external_control_port=EXTERNAL_CONTROL_PORT, remote_control=True, **controller_options):
        """`external_control_host`/`_port`: where an External Control URCap node fetches its program (the remote
        PC of the URCap's installation settings; default this simulator's own address, port 50002).
        `remote_control`: the dashboard's `is in remote control` (e-series 5.6+; False as URSim by default)."""
        self.host = host
        self.controller = Controller(model=model, version=version, initial_q=initial_q, calibration=calibration,
                                     frequency=frequency, **controller_options)
        self.controller.programs_directory = programs_directory
        pendant_settings(self.controller).remote_control = bool(remote_control)
        self.runner = ProgramRunner(self.controller)
        self.controller.attach_program_runner(self.runner)
        self.programs = ProgramTab(self.controller, ExternalControlSettings(external_control_host or host,
                                                                            external_control_port))
        self.servers = {
            "dashboard": DashboardServer(self.controller, host, DASHBOARD_PORT, on_shutdown=self.request_stop,
                                         programs=self.programs),
            "primary": PrimaryServer(self.controller, host, PRIMARY_PORT),
            "secondary": SecondaryServer(self.controller, host, SECONDARY_PORT),
            "realtime": RealtimeServer(self.controller, host, REALTIME_PORT),
            "rtde": RTDEServer(self.controller, host, RTDE_PORT),
            "control": ControlChannelServer(self, host, CONTROL_PORT),
        }
        self._stopped = threading.Event()
        self._stop_lock = threading.Lock()
        self._started = False

    @property
    def ports(self) -> dict[str, int]:
        """{server name: port} of every server."""
        return {name: server.port for name, server in self.servers.items()}

    def start(self) -> "Simulator":
        """Start the control loop, then every server (a server that fails to bind stops the ones already started)."""
        self.controller.start()
        self._started = True
        started = []
        try:
            for server in self.servers.values():
                server.start()
                started.append(server)
        except OSError:
            for server in reversed(started):
                server.stop()
            self.controller.shutdown()
            self._started = False
            raise
        log.info("sim_ursim %s (software %s) serving on %s: %s", self.controller.model.name, self.controller.version,
                 self.host, ", ".join(f"{name} {port}" for name, port in self.ports.items()))
        return self

    def request_stop(self) -> None:
        """Stop the simulator soon, from any thread (dashboard `shutdown`, control channel, SIGTERM)."""
        log.info("shutdown requested")
        self._stopped.set()
        threading.Thread(target=self.stop, name="sim_ursim-shutdown", daemon=True).start()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until a stop is requested or done (True) or `timeout` passes (False)."""
        return self._stopped.wait(timeout)

    def stop(self) -> None:
        """Stop every server, the program and the control loop (idempotent; a second caller waits for the first)."""
        with self._stop_lock:
            if not self._started:
                return
            self._stopped.set()
            servers = list(reversed(self.servers.values()))
            for server in servers:   # all first, then the joins: the threads end within one poll together
                try:
                    server.begin_stop()
                except Exception:  # noqa: BLE001 - one failing server must not keep the others running
                    log.exception("stopping a server failed")
            for server in servers:
                server.join()
            self.controller.shutdown()
            self._started = False
            log.info("sim_ursim on %s stopped", self.host)

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
