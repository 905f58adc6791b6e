"""The stored poses planned on the nominal model, without a robot (what `plot` draws and `export-urscript`
writes)."""
from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from rich.console import Console

from ur3dq.cli.app import Settings, solving_poses
from ur3dq.cli.options import speed_and_acceleration
from ur3dq.errors import StoreError
from ur3dq.replay import PlanStep, plan_replay

if TYPE_CHECKING:
    from ur3dq.kinematics.models import URModel


def offline_plan(settings: Settings, names: Iterable[str] | None, speed: float, acceleration: float,
                 replay_joints: bool, max_travel: float | None) -> tuple[URModel, list[PlanStep], float, float]:
    """(model, plan, a, v) of the stored poses on the nominal model (--model, else the first pose's), no robot."""
    from ur3dq.kinematics import robot_model

    poses = settings.store.select(names)
    if not poses:
        raise StoreError(f"{settings.store_path} has no poses: record some with `ur3dq record-pose`")
    model = robot_model(settings.model or poses[0].robot_model)
    solving_poses(len(poses), model)
    a, v = speed_and_acceleration(model, speed, acceleration, Console(stderr=True, highlight=False), settings.units)
    return model, plan_replay(model, poses, None, a, v, replay_joints, max_travel), a, v
