"""CLI tests run the installed `ur3dq` command in real subprocesses, with their own store, state dir and sim."""
import subprocess
import time

import pytest

from cli_support import UR3DQ, SimulatedArm, cli_env


@pytest.fixture
def run_cli(tmp_path):
    """run_cli(*args, input=None, env=None) -> CompletedProcess of `ur3dq args` in `tmp_path` (text, captured)."""

    def run(*args, input=None, timeout=90, **extra_env):
        return subprocess.run([UR3DQ, *map(str, args)], cwd=tmp_path, env=cli_env(tmp_path, **extra_env),
                              input=input if input is not None else "", capture_output=True, text=True,
                              timeout=timeout)

    return run


@pytest.fixture(scope="module")
def arm():
    """One simulated UR3 per test module (a subprocess: ur_rtde in this process holds the GIL while it blocks)."""
    import dashboard_client
    from sim_ursim.testing import simulator_process

    with simulator_process(model="ur3") as simulator:
        dashboard = dashboard_client.DashboardClient(simulator.host)
        dashboard.connect()
        dashboard.powerOn()
        dashboard.brakeRelease()
        simulated = SimulatedArm(simulator.host)
        deadline = time.monotonic() + 15
        while simulated.receive.getRobotMode() != 7:  # RUNNING
            assert time.monotonic() < deadline, "the simulator did not reach RUNNING"
            time.sleep(0.05)
        dashboard.disconnect()
        try:
            yield simulated
        finally:
            simulated.receive.disconnect()
