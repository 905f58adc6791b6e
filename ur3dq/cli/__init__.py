"""The `ur3dq` command line (click): importing this package registers every command on `cli`."""
import os

# One BLAS thread, set before numpy is first imported (ur3dq's own package imports none). A command's matrices are
# small; OpenBLAS's extra threads only spin, taking CPU from the heartbeat and state threads of a driver on a small
# cell PC (docs/performance.md). A value the user set is kept.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

# Importing the command modules registers their commands; `ur3dq X` lives in cli/X.py.
from ur3dq.cli import check, demo, export_urp, export_urscript, fk, ik, import_urp, jog, move_to, plot, poses, record_pose, robot, run_poses, serve, sim, status  # noqa: E402,F401,I001,E501
from ur3dq.cli.app import cli, main  # noqa: E402  (after the thread count)

__all__ = ["cli", "main"]
