"""The warning lines of a planned cell program, the same wherever a plan is shown or written (run-poses' summary and
--plan, its --json `warnings`, check, plot, export-urscript, export-urp): what the plan lowered to the model's
limits, a blend the technician set that the plan drops, and URScript kept from a PolyScope program.

Use `plan_warnings(plan, units)` for all of them, in that order; each line names its step and why.
"""
from __future__ import annotations

from collections.abc import Sequence

from ur3dq.cli.path_report import kept_script_warnings
from ur3dq.program.plan import PlannedStep
from ur3dq.program.steps import Comment, is_waypoint
from ur3dq.units import ACCELERATION, LENGTH, SPEED, Units, angular_kind, show


def plan_warnings(plan: Sequence[PlannedStep], units: Units) -> list[str]:
    """Every warning line of `plan` (clamps, dropped blends, kept script), numbers in `units`."""
    return clamp_warnings(plan, units) + dropped_blend_warnings(plan, units) + kept_script_warnings(plan)


def clamp_warnings(plan: Sequence[PlannedStep], units: Units) -> list[str]:
    """One line per step whose speed or acceleration the plan lowered to the model's limits, in `units`:
    "'above': speed lowered to 3.14159 rad/s (joint move limit)"."""
    lines = []
    for planned in plan:
        if planned.clamped:
            angular = angular_kind(planned.move or "joint")
            shown = units if angular else Units(units.angle, "mm")   # linear speeds in mm/s, as on the pendant
            lowered = [f"{what} lowered to {show(value, kinds[angular], shown)}" for what, value, kinds in (
                ("speed", planned.speed, SPEED), ("acceleration", planned.acceleration, ACCELERATION))
                if any(text.startswith(what) for text in planned.clamped) and value is not None]
            lines.append(f"{planned.step.name!r}: {', '.join(lowered)} ({planned.move} move limit)")
    return lines


def dropped_blend_warnings(plan: Sequence[PlannedStep], units: Units) -> list[str]:
    """One line per waypoint whose own blend radius (set with `poses set --blend`) the plan sets to 0, and why:
    it is the last waypoint of the plan (the arm stops there), or an action step follows it (the action happens
    at the waypoint, so the arm stops there first). A run-wide --blend dropped at those places is not warned of:
    stopping there is what it means."""
    lines = []
    for index, planned in enumerate(plan):
        step = planned.step
        own = step.motion.blend if is_waypoint(step) else None
        if not own or planned.blend > 0:
            continue
        radius = show(own, LENGTH, Units(units.angle, "mm"))
        after = next((later.step for later in plan[index + 1:] if not isinstance(later.step, Comment)), None)
        if after is None:
            why = "it is the last waypoint of the plan: the arm stops there"
        else:
            why = (f"the {after.kind} step {after.name!r} follows: the action happens at the waypoint, so the arm "
                   "stops there first")
        lines.append(f"{step.name!r}: blend {radius} not used, {why}")
    return lines
