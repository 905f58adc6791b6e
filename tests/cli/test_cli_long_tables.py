"""A store too long for rich tables (over PLAIN_TABLE_ROWS poses): the plans print as tab-separated lines, on
stderr under --json so that stdout stays one JSON document, and the whole path is still checked."""
import json

import numpy as np
import pytest

from ur3dq.cli.display import PLAIN_TABLE_ROWS
from ur3dq.dqarray import to_ur_pose
from ur3dq.kinematics import robot_model
from ur3dq.store_format import SCHEMA_NAME, SCHEMA_VERSION

UR3 = robot_model("ur3")


@pytest.fixture
def long_store(tmp_path):
    """PLAIN_TABLE_ROWS + 1 poses of a UR3 along a small random walk of its joints (written as the store's file
    format, one pose per line: adding them one by one would rewrite the file each time)."""
    count = PLAIN_TABLE_ROWS + 1
    steps = np.random.default_rng(3).uniform(-0.05, 0.05, (count, 6))
    joints = np.array([0.0, -1.5, 1.2, -1.5, -1.57, 0.0]) + np.cumsum(steps, axis=0)
    poses = UR3.fk_batch(joints)
    entries = [json.dumps({"name": f"pose-{i + 1}", "time": "2026-11-26T05:00:00.000Z", "robot_model": "ur3",
                           "robot_serial": None, "joints": joints[i].tolist(), "dual_quaternion": poses[i].tolist(),
                           "ur_pose": to_ur_pose(poses[i]).tolist(), "tcp_offset": [0.0] * 6, "note": ""})
               for i in range(count)]
    path = tmp_path / "long.json"
    body = ",\n".join(entries)
    path.write_text(f'{{"schema": "{SCHEMA_NAME}", "version": {SCHEMA_VERSION}, "poses": [\n{body}\n]}}\n',
                    encoding="utf-8")
    return path


@pytest.mark.parametrize("selection, header", [((), "#\tpose\tjoints (rad)\tchosen by"),
                                               (("--from", "pose-1"), "#\tstep\ttype\ttarget joints (rad) / action")])
def test_a_long_plan_is_tab_separated_and_json_output_stays_one_document(run_cli, long_store, selection, header):
    result = run_cli("--json", "--store", long_store, "run-poses", "--dry-run", *selection, timeout=120)
    assert result.returncode == 0, result.stderr
    document = json.loads(result.stdout)            # the plan table went to stderr, not into the JSON
    assert len(document["plan"]) == PLAIN_TABLE_ROWS + 1
    lines = result.stderr.splitlines()
    assert any(line.startswith(header) for line in lines)
    assert sum(line.count("\t") >= 6 for line in lines) >= PLAIN_TABLE_ROWS + 1
    plain = run_cli("--store", long_store, "run-poses", "--dry-run", *selection, timeout=120)
    assert plain.returncode == 0, plain.stderr
    assert f"pose-{PLAIN_TABLE_ROWS + 1}\t" in plain.stdout
    assert f"of {PLAIN_TABLE_ROWS + 1} moves shown" in plain.stdout
