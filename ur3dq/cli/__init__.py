"""The `ur3dq` command line (click): importing this package registers every command on `cli`."""
from ur3dq.cli.app import cli, main
from ur3dq.cli import (  # noqa: F401  (importing registers the commands)
    commands_check, commands_controller, commands_files, commands_kinematics, commands_poses, commands_program,
    commands_robot, commands_sim,
)

__all__ = ["cli", "main"]
