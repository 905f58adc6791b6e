"""The run question of run-poses fits a 24-row terminal with its summary (steps, time, travel, the check's verdict,
warnings), the full plan one flag away; the embedded simulator keeps its address, and a refused host says where
ur3dq's simulator runs."""
import shutil
import signal
from pathlib import Path

import numpy as np

from cli_support import Terminal

EXAMPLE = Path(__file__).parents[2] / "poses" / "example-poses.json"


def thirteen_steps(run_cli):
    """A 13-step cell program on the example poses: approach/retract offsets, linear moves, outputs, waits."""
    for args in (("poses", "offset", "above-1", "--from", "demo-1", "--z", "-50mm", "--before", "demo-1"),
                 ("poses", "set", "demo-1", "--move", "linear", "--speed", "100mm/s"),
                 ("poses", "add-step", "--after", "demo-1", "tool-out", "0", "on"),
                 ("poses", "add-step", "--after", "tool-out-1", "wait", "500ms"),
                 ("poses", "offset", "retract-1", "--from", "demo-1", "--z", "-50mm", "--after", "wait-1", "--move",
                  "linear", "--speed", "100mm/s"),
                 ("poses", "add-step", "--after", "demo-2", "tool-out", "0", "off"),
                 ("poses", "add-step", "--after", "tool-out-2", "wait", "500ms"),
                 ("poses", "add-step", "--after", "demo-3", "message", "half way"),
                 ("poses", "add-step", "--after", "message-1", "wait", "1s"),
                 ("poses", "add-step", "--after", "demo-4", "message", "done"),
                 ("poses", "set", "demo-4", "--speed", "500deg/s", "--deg")):
        result = run_cli(*args)
        assert result.returncode == (4 if "500deg/s" in args else 0), result.stderr


def test_the_question_and_its_summary_fit_24_rows(run_cli, arm, tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    thirteen_steps(run_cli)
    result = run_cli("--host", arm.host, "run-poses", "--max-travel", "360deg", input="n\n", COLUMNS="80")
    assert result.returncode == 1, result.stderr      # answered no: nothing moved
    shown = (result.stdout + result.stderr).splitlines()
    question = next((i for i, line in enumerate(shown) if "Run 13 steps" in line), None)
    assert question is not None, "\n".join(shown)
    assert question + 2 <= 24, "\n".join(shown)        # the command line, the summary and the question: one screen
    summary = "\n".join(shown[:question])
    assert "Plan: 13 steps, 'above-1' to 'message-2'" in summary and "2 linear" in summary and "about" in summary
    assert "Path check (no cell file): clear" in summary and "--plan" in summary
    assert max(len(line) for line in shown) <= 80
    full = run_cli("--host", arm.host, "run-poses", "--max-travel", "360deg", "--plan", input="n\n", COLUMNS="80")
    assert "retract-1" in full.stdout and "° from singular" in full.stdout and "Run 13 steps" in full.stderr


def test_the_simulator_keeps_its_address_and_a_refused_host_points_at_it(run_cli):
    first = run_cli("sim", "start")
    try:
        host = first.stdout.split("serving on ")[1].split()[0]
        assert run_cli("sim", "stop").returncode == 0
        second = run_cli("sim", "start")
        assert second.returncode == 0 and f"serving on {host} " in second.stdout
        stale = run_cli("status", UR3DQ_HOST="127.9.9.9")
        assert stale.returncode == 5
        assert f"UR3DQ_HOST names 127.9.9.9, but `ur3dq sim start`'s simulator runs on {host}" in stale.stderr
        assert "`unset UR3DQ_HOST`" in stale.stderr
    finally:
        run_cli("sim", "stop")
    nothing = run_cli("--host", "127.9.9.9", "status")
    assert "no ur3dq simulator is running" in nothing.stderr and "ur3dq sim start" in nothing.stderr


def test_ctrl_c_at_the_run_question_cancels_and_exits_130(run_cli, arm, tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    thirteen_steps(run_cli)
    before = arm.joints()
    terminal = Terminal(tmp_path, "--host", arm.host, "run-poses", "--max-travel", "360deg")
    try:
        terminal.wait_for("Run 13 steps")
        terminal.wait_for("[y/N]")
        terminal.process.send_signal(signal.SIGINT)   # Ctrl-C (this pty is not the process's controlling tty)
        terminal.wait_for('Cancelled at "Run 13 steps')
        terminal.process.wait(20)
        rest = terminal.text
    finally:
        terminal.close()
    assert terminal.process.returncode == 130, rest
    assert "(Ctrl-C): nothing done." in rest and "Error" not in rest, rest
    np.testing.assert_allclose(arm.joints(), before, atol=1e-9)
