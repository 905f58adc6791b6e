"""URScript `speedl(xd, a, t)` with t > 0 runs in lockstep with the control cycles, as speedj does (docs/ursim.md):
it moves for exactly t of controller time, the arm then waits for the thread's next command, and ramps to rest at
`a` when the thread sleeps, syncs or ends. URCL's External Control speedl thread sends one `speedl(twist, 40,
steptime)` per cycle; positions integrated from such steps must be where the arm ends."""
import math

import numpy as np

from polling import wait_for
from sim_ursim.launch import running_simulator

STEPS = 250  # one half sine of TCP speed along base z, one speedl per control cycle (0.5 s at 500 Hz)
PEAK_SPEED = 0.1  # m/s

# Each step's acceleration is the change of speed over the step (plus a margin), so the ramp reaches the step's
# speed within its first cycle, as URCL computes it for speedj: the TCP then travels Σ v_k · steptime.
STEPPED_PROGRAM = f"""def steppedSpeedl():
  steptime = get_steptime()
  last_v = 0.0
  k = 1
  while k <= {STEPS}:
    v = {PEAK_SPEED} * sin({math.pi} * k / {STEPS})
    speedl([0, 0, v, 0, 0, 0], norm(v - last_v) / steptime + 0.01, steptime)
    last_v = v
    k = k + 1
  end
  speedl([0, 0, 0, 0, 0, 0], norm(last_v) / steptime + 0.01, steptime)
  write_output_integer_register(0, 1)
end
"""


def test_speedl_stepped_each_cycle_ends_where_its_speeds_integrate_to():
    """Before the lockstep the twist ran on while the interpreter prepared the next step, so the TCP went further
    than the integrated speeds (the time between two speedl was wall time, not the commanded t)."""
    with running_simulator(model="ur5e") as sim:
        controller = sim.controller
        controller.power_up()
        steptime = controller.period
        start = np.array(controller.state().actual_tcp_pose)
        assert controller.run_program(STEPPED_PROGRAM, "test")
        assert wait_for(lambda: controller.state().output_int_registers[0] == 1, timeout=60)
        assert wait_for(lambda: not controller.state().motion_active, timeout=5)
        travelled = np.array(controller.state().actual_tcp_pose) - start
        expected_z = sum(PEAK_SPEED * math.sin(math.pi * k / STEPS) for k in range(1, STEPS + 1)) * steptime
        assert abs(travelled[2] - expected_z) < 1e-4, f"travelled {travelled[2]:.6f} m along z, not {expected_z:.6f}"
        assert np.max(np.abs(travelled[:2])) < 1e-4


def test_a_speedl_with_time_that_nothing_follows_moves_for_t_then_ramps_to_rest():
    """speedl([0, 0, 0.05, …], 5, 0.1) then sleep: 0.1 s at 5 cm/s (ramps of 0.01 s at each end), then rest —
    not on through the sleep."""
    with running_simulator(model="ur5e") as sim:
        controller = sim.controller
        controller.power_up()
        start = np.array(controller.state().actual_tcp_pose)
        program = "def alone():\n  speedl([0, 0, 0.05, 0, 0, 0], 5.0, 0.1)\n  sleep(0.5)\nend\n"
        assert controller.run_program(program, "test")
        assert wait_for(lambda: not controller.state().program_running, timeout=10)
        assert wait_for(lambda: not controller.state().motion_active, timeout=5)
        assert max(abs(v) for v in controller.state().actual_tcp_speed) < 1e-9
        travelled = float(np.array(controller.state().actual_tcp_pose)[2] - start[2])
        assert abs(travelled - 0.005) < 2e-4, f"travelled {travelled:.6f} m, expected 0.005 (0.1 s at 0.05 m/s)"
