"""The warning lines of a planned cell program, the same wherever a plan is shown or written (run-poses' summary and
--plan, its --json `warnings`, check, plot, export-urscript, export-urp): what the plan lowered to the model's
limits and URScript kept from a PolyScope program.

Use `plan_warnings(plan, units)` for all of them, in that order; each line names its step and why.
"""
from __future__ import annotations

from collections.abc import Sequence

from ur3dq.cli.path_report import kept_script_warnings
from ur3dq.program.plan import PlannedStep
from ur3dq.units import ACCELERATION, SPEED, Units, angular_kind, show


def plan_warnings(plan: Sequence[PlannedStep], units: Units) -> list[str]:
    """Every warning line of `plan` (clamps, kept script), numbers in `units`."""
    return clamp_warnings(plan, units) + kept_script_warnings(plan)


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
