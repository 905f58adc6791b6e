"""sim_ursim: a protocol-level Universal Robots controller simulator that unmodified UR clients talk to over TCP.

Start one with `python -m sim_ursim --host 127.0.0.2` or, in tests, `sim_ursim.launch.running_simulator()`.
The package never imports ur3dq: the robot side stays independent of the client side.
"""
