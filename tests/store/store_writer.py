"""A writer process for the store's crash and concurrency tests: adds COUNT poses named PREFIX-N to STORE, printing
each name (flushed) once `add` has returned, i.e. once the pose is committed."""
import sys

import numpy as np
from pyquaternion import Quaternion

from ur3dq.dualquat import DualQuaternion
from ur3dq.pose import Pose
from ur3dq.store import PoseStore


def main(store_path: str, prefix: str, count: int) -> None:
    store = PoseStore(store_path)
    rng = np.random.default_rng(abs(hash(prefix)) % 2**32)
    for index in range(1, count + 1):
        pose = DualQuaternion.from_rotation_translation(Quaternion.random(), rng.uniform(-0.5, 0.5, 3))
        joints = rng.uniform(-3, 3, 6)
        stored = store.add(Pose.from_dual_quaternion(f"{prefix}-{index}", pose, "ur3", joints=joints))
        print(stored.name, flush=True)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]))
