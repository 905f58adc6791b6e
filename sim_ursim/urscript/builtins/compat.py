"""Built-ins for what the simulator does not model (force control parameters, F/T sensor, dynamics) and the RTDE
input watchdog.

Those with a harmless meaning here (accepting a parameter, a sensor that reads zero) are checked and accepted; the
rest exist so that scripts using them compile, as on the controller, and raise a run-time error naming themselves
when called (`UNSUPPORTED`).
"""
from sim_ursim.rtde.watchdog import watchdogs_of
from sim_ursim.urscript.builtins.arguments import as_number
from sim_ursim.urscript.builtins.registry import builtin, register
from sim_ursim.urscript.script_thread import ThreadContext
from sim_ursim.urscript.values import ScriptError, number_list, to_str


@builtin
def rtde_set_watchdog(ctx: ThreadContext, variable_name, min_frequency, action="pause"):
    """Arm the RTDE input watchdog of `variable_name` (sim_ursim.rtde.watchdog): pause/stop/ignore when the input
    is not updated at `min_frequency` Hz; removed when this program stops."""
    if not isinstance(variable_name, str):
        raise ScriptError(f"runtime_error:rtde_set_watchdog needs a variable name, got {to_str(variable_name)}:")
    execution = ctx.execution
    try:
        watchdogs_of(ctx.controller).arm(variable_name, as_number(min_frequency, "min_frequency"), to_str(action),
                                         lambda: execution.main.done.is_set() or execution.main.cancel.is_set())
    except ValueError as error:
        raise ScriptError(f"runtime_error:rtde_set_watchdog: {error}:") from None


@builtin("force_mode_set_damping", "force_mode_set_gain_scaling")
def force_mode_parameter(ctx: ThreadContext, value):
    """Force-mode damping / gain scaling (0..1): checked and accepted; force mode itself is not emulated."""
    value = as_number(value, "value")
    if not 0.0 <= value <= 2.0:
        raise ScriptError(f"runtime_error:force mode parameter must be 0..2, got {to_str(value)}:")


@builtin
def set_gravity(ctx: ThreadContext, d):
    """Gravity direction [m/s²] in the base frame: checked and accepted; the simulator models no dynamics."""
    number_list(d, 3, "d")


@builtin
def tool_contact(ctx: ThreadContext, direction):
    """Cycles since the tool touched something along `direction`: always 0, the simulated arm never collides."""
    number_list(direction, 6, "direction")
    return 0


@builtin
def zero_ftsensor(ctx: ThreadContext):
    """Zero the F/T sensor: the simulated sensor always reads zero, so nothing changes."""


def _unsupported(name):
    """A built-in that raises a run-time error naming `name`."""

    def refuse(ctx: ThreadContext, *args, **kwargs):
        raise ScriptError(f"runtime_error:{name} is not supported by sim_ursim:")

    refuse.__name__ = name
    return refuse


UNSUPPORTED = (
    "servoc",
    "direct_torque", "get_mass_matrix", "get_coriolis_and_centrifugal_torques",
    "get_jacobian_time_derivative", "teach_mode_set_params", "set_analog_inputrange",
)
for _name in UNSUPPORTED:
    register(_name, _unsupported(_name))
