"""`ur3dq status` shows the I/O (digital standard/configurable/tool inputs and outputs, analog) and the program
state, read from a simulated controller whose outputs a program set and whose input a hand switched."""
import json
import socket
import time

from sim_ursim.control_channel import send_request


def test_status_shows_the_outputs_a_program_set_and_the_inputs_that_are_on(run_cli, arm):
    assert send_request(arm.host, "set-digital-input", pin=2, on=True).get("ok")
    with socket.create_connection((arm.host, 30002)) as primary:   # a gripper program: tool output 0 on
        primary.sendall(b"set_tool_digital_out(0, True)\nset_standard_digital_out(5, True)\n")
    deadline = time.monotonic() + 10
    while True:
        result = run_cli("--host", arm.host, "status", "--json")
        assert result.returncode == 0, result.stderr
        io = json.loads(result.stdout)["io"]
        if io["digital_out"]["tool"][0] or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    assert io["digital_out"]["tool"] == [True, False]
    assert io["digital_out"]["standard"][5] and sum(io["digital_out"]["standard"]) == 1
    assert io["digital_in"]["standard"][2] and sum(io["digital_in"]["standard"]) == 1
    assert io["runtime_state"] in ("STOPPED", "PLAYING")
    table = run_cli("--host", arm.host, "status", COLUMNS="80").stdout
    assert "standard 5; tool 0" in table and "standard 2" in table
    assert "program" in table and max(len(line) for line in table.splitlines()) <= 80
    assert len(table.splitlines()) <= 22   # with the prompt and the command line: one 24-row screen
