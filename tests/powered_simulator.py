"""A simulator process powered and RUNNING, for the tests that need a ready arm outside the driver's fixtures."""
import contextlib

from polling import wait_for


@contextlib.contextmanager
def powered_simulator(model="ur3", **options):
    """A running `sim_ursim` process (options as sim_ursim.launch.simulator_process) powered on with its brakes
    released through the dashboard, as an operator would, once the controller is RUNNING (read on its control
    channel: an RTDE client here would cost a second to open and close)."""
    import dashboard_client

    from sim_ursim.control_channel import send_request
    from sim_ursim.launch import simulator_process

    with simulator_process(model=model, **options) as simulator:
        dashboard = dashboard_client.DashboardClient(simulator.host)
        dashboard.connect()
        dashboard.powerOn()
        dashboard.brakeRelease()
        dashboard.disconnect()
        running = wait_for(lambda: send_request(simulator.host, "status")["state"]["robot_mode"] == "RUNNING",
                           timeout=15)
        assert running, "the simulator never got RUNNING"
        yield simulator
