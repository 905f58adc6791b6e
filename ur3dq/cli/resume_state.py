"""What `run-poses --resume` needs after a stop or a fault, kept next to the pose store (`<store>.resume`).

A run that ends early writes the step it was running, the run's options, a digest of the store's bytes and the
arm it ran on; the file is replaced atomically (ur3dq.store.write_atomically), so a crash leaves the old state or
the new one, never half of either. A run that goes to its end removes it. `--resume` refuses, naming the reason,
when the file is missing or unreadable, when the store changed since (a re-taught pose would make "the same step"
another motion), or when the arm is another one (model, serial number where the controller tells it, and its
calibration).
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from ur3dq.errors import SafetyCheckError
from ur3dq.pose import utc_now_iso
from ur3dq.store import RESUME_SUFFIX, write_atomically

FORMAT = 1
KINDS = ("program", "replay")


def resume_path(store_path: str | os.PathLike[str]) -> Path:
    """Where the resume state of the store at `store_path` lives: `<store>.resume` beside the store (of a
    symlink's target, as its lock)."""
    return Path(os.path.realpath(store_path) + RESUME_SUFFIX)


def store_digest(store_path: str | os.PathLike[str]) -> str:
    """SHA-256 of the store file's bytes ('' when there is no file)."""
    try:
        return hashlib.sha256(Path(store_path).read_bytes()).hexdigest()
    except FileNotFoundError:
        return ""


def arm_identity(robot: Any) -> dict[str, Any]:
    """What says which arm `robot` (a connected ur3dq Robot) is: its model, serial number (None where the
    controller does not tell it, before PolyScope 5.6) and a digest of its calibrated kinematics."""
    dh = robot.model.dh
    numbers = np.round(np.concatenate([dh.a, dh.d, dh.alpha, dh.theta]), 9) + 0.0   # + 0.0: no -0.0
    return {"model": robot.model_name, "serial": robot.serial_number,
            "calibration": hashlib.sha256(numbers.tobytes()).hexdigest()[:16]}


@dataclasses.dataclass(frozen=True)
class ResumeState:
    """A stopped run: `kind` 'program' (a cell program, from the step named `step` at 1-based `position`, up to
    `end` or the program's end) or 'replay' (stored poses: `names` left to replay, `step` the first of them);
    `options` the run's options (speeds, blend, cell, ...); `reason` why it stopped; `store_digest` and `arm`
    what it ran with."""

    kind: str
    position: int
    step: str
    end: str | None
    names: tuple[str, ...]
    options: dict[str, Any]
    reason: str
    store_digest: str
    arm: dict[str, Any]
    time: str = ""

    def write(self, store_path: str | os.PathLike[str]) -> None:
        """Write this state beside the store, atomically."""
        data = {"ur3dq_resume": FORMAT, **dataclasses.asdict(self), "names": list(self.names),
                "time": self.time or utc_now_iso()}
        write_atomically(resume_path(store_path), json.dumps(data, indent=2) + "\n")

    def require_same_store(self, store_path: str | os.PathLike[str]) -> None:
        """SafetyCheckError naming the fix when the store's bytes are no longer those the run had."""
        if store_digest(store_path) != self.store_digest:
            raise SafetyCheckError(
                f"resume refused: {store_path} changed since the run stopped at step {self.position} "
                f"{self.step!r} (the same step may now be another motion); run the program again, or from a step "
                f"with `run-poses --from NAME`")

    def require_same_arm(self, robot: Any) -> None:
        """SafetyCheckError naming both arms when `robot` is not the arm the run stopped on."""
        now = arm_identity(robot)
        if now != self.arm:
            def text(arm: dict[str, Any]) -> str:
                serial = f" serial {arm['serial']}" if arm.get("serial") else ""
                return f"a {arm.get('model')}{serial} (calibration {arm.get('calibration')})"
            raise SafetyCheckError(f"resume refused: the run stopped on {text(self.arm)}, and {robot.host} is "
                                   f"{text(now)}; connect to that arm (--host), or run the program again here")


def load_resume_state(store_path: str | os.PathLike[str]) -> ResumeState:
    """The resume state of the store at `store_path`; SafetyCheckError naming the reason when there is none that
    can be used."""
    path = resume_path(store_path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SafetyCheckError(f"nothing to resume: no run of {store_path} stopped early (or it was run to its "
                               "end since); run `ur3dq run-poses`") from None
    except (OSError, ValueError) as error:
        raise SafetyCheckError(f"resume refused: {path} cannot be read ({error}); run the program again") from None
    try:
        if data.pop("ur3dq_resume") != FORMAT or data["kind"] not in KINDS:
            raise ValueError("unknown format")
        return ResumeState(**{**data, "names": tuple(data["names"]), "position": int(data["position"])})
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise SafetyCheckError(f"resume refused: {path} is not a resume state this ur3dq wrote ({error}); run "
                               "the program again") from None


def clear_resume_state(store_path: str | os.PathLike[str]) -> None:
    """Remove the resume state (the run went to its end): nothing is left to resume."""
    try:
        resume_path(store_path).unlink()
    except FileNotFoundError:
        pass
