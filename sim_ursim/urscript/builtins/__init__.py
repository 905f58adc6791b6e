"""URScript built-in functions, by family; importing this package fills `BUILTINS` (name -> function).

registry.py   BUILTINS, the @builtin decorator     arguments.py  argument conversions, refusals -> script errors
maths.py      trigonometry, rounding, text, bits   poses.py      pose composition, distances, interpolation, RPY
motion.py     moves, speed/servo, stops, waits     kinematics.py FK, IK, reachability, Jacobian
settings.py   TCP, payload, state getters          io.py         digital/analog I/O, registers
messages.py   textmsg, popup                       compat.py     accepted no-ops, RTDE watchdog, unsupported
sockets.py    socket_* (connections to clients)    clients.py    what UR's client scripts use beyond these:
                                                                 strings, matrices, movec, force_mode, analog in

A new family is a module that registers with `@builtin` (or `register` for generated ones), imported below.
Every built-in is `f(ctx, *args)` where `ctx` is the calling script thread's ThreadContext; bad arguments raise
ScriptError (the interpreter adds line and column).
"""
from sim_ursim.urscript.builtins import (  # noqa: F401
    clients,
    compat,
    io,
    kinematics,
    maths,
    messages,
    motion,
    poses,
    settings,
    sockets,
)
from sim_ursim.urscript.builtins.registry import BUILTINS, builtin, register

__all__ = ["BUILTINS", "builtin", "register"]
