"""A simulator process powered and RUNNING, for the tests that need a ready arm outside the driver's fixtures."""
import contextlib

from polling import wait_for


@contextlib.contextmanager
def powered_simulator(model="ur3", **options):
    """A running `sim_ursim` process (options as sim_ursim.launch.simulator_process) powered on with its brakes
    released through the dashboard, as an operator would, once RTDE shows it RUNNING."""
    import dashboard_client
    import rtde_receive

    from sim_ursim.launch import simulator_process

    with simulator_process(model=model, **options) as simulator:
        dashboard = dashboard_client.DashboardClient(simulator.host)
        dashboard.connect()
        dashboard.powerOn()
        dashboard.brakeRelease()
        dashboard.disconnect()
        receive = rtde_receive.RTDEReceiveInterface(simulator.host)
        try:
            assert wait_for(lambda: receive.getRobotMode() == 7, timeout=15), "the simulator never got RUNNING"
        finally:
            receive.disconnect()
        yield simulator
