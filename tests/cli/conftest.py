"""CLI tests run the installed `ur3dq` command in real subprocesses, with their own store, state dir and sim."""
import io
import os
import subprocess
import sys

import pytest

from cli_support import UR3DQ, SimulatedArm, cli_env
from ur3dq.cli import load_all_commands

load_all_commands()   # the tests that walk cli.commands see every command (a command line imports only its own)


@pytest.fixture
def run_cli(tmp_path):
    """run_cli(*args, input=None, env=None) -> CompletedProcess of `ur3dq args` in `tmp_path` (text, captured)."""

    def run(*args, input=None, timeout=90, **extra_env):
        return subprocess.run([UR3DQ, *map(str, args)], cwd=tmp_path, env=cli_env(tmp_path, **extra_env),
                              input=input if input is not None else "", capture_output=True, text=True,
                              timeout=timeout)

    return run


@pytest.fixture
def run_in_process(tmp_path, monkeypatch, capsys):
    """Like run_cli, but `ur3dq.cli.main` in this process (same code path, no interpreter start-up): for the many
    bad-input cases that never reach a robot."""
    from ur3dq.cli import main

    def run(*args, input=""):
        monkeypatch.chdir(tmp_path)
        for key in [key for key in os.environ if key.startswith("UR3DQ_")]:
            monkeypatch.delenv(key)
        monkeypatch.setenv("UR3DQ_STATE_DIR", str(tmp_path / "state"))
        # main() marks this process as the command's own, where `fk`, `ik` and `record-pose` switch the kernels to
        # Python for the rest of the process (NUMBA_DISABLE_JIT=1): undone after the test, or every later test and
        # subprocess of this worker would run them interpreted.
        monkeypatch.setattr("ur3dq.cli.app._OWN_PROCESS", False)
        monkeypatch.setenv("NUMBA_DISABLE_JIT", os.environ.get("NUMBA_DISABLE_JIT") or "0")
        monkeypatch.setattr(sys, "stdin", io.StringIO(input))
        capsys.readouterr()
        with pytest.raises(SystemExit) as exit_info:
            main([str(arg) for arg in args])
        out, err = capsys.readouterr()
        return subprocess.CompletedProcess(args, exit_info.value.code, out, err)

    return run


@pytest.fixture(scope="module")
def arm():
    """One simulated UR3 per test module (a subprocess: ur_rtde in this process holds the GIL while it blocks)."""
    from powered_simulator import powered_simulator

    with powered_simulator(model="ur3") as simulator:
        simulated = SimulatedArm(simulator.host)
        try:
            yield simulated
        finally:
            simulated.receive.disconnect()
