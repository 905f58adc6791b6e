"""What PolyScope cannot hold, in `ur3dq: {...}` comments: written by the export right before the node they are
about, read back by the import.

A relative waypoint's base, offset and frame, and a note (`{"relative to": "pick", "offset": [...], "frame":
"tool"}`, `{"note": "..."}`) go before its fixed waypoint; an input wait's timeout (`{"timeout": 10.0}`) before the
Wait node; the run's defaults (`{"run defaults": {"speed": 1.05, "acceleration": 1.4}}`) first in a Move, whose
speed and acceleration they are, so that its waypoints that set none of their own come back without their own. A
technician's edit on the pendant wins: a moved relative waypoint comes back fixed, a Move whose values changed
keeps them.

>>> from polyscope_format.urp_xml import element
>>> annotation_of(element("Comment", {"comment": 'ur3dq: {"timeout": 10.0}'}))
{'timeout': 10.0}
"""
from __future__ import annotations

import json
from xml.etree.ElementTree import Element

from ur3dq.dualquat import DualQuaternion
from ur3dq.program.resolve import resolve_targets
from ur3dq.program.steps import RelativeWaypoint, Step, Waypoint

ANNOTATION = "ur3dq: "
RUN_DEFAULTS = "run defaults"   # a Move's annotation: its waypoints without own values take the run's defaults


def relative_from_annotations(steps: list[Step], annotated: dict[str, dict[str, object]],
                              warnings: list[str]) -> list[Step]:
    """`steps` with each fixed waypoint whose `ur3dq: ` annotation (in `annotated`, by name) names a base and an
    offset made a relative waypoint again, where its recorded pose is still that offset from its base (else it
    stays fixed, with a warning: it was moved on the pendant, or its base was)."""
    if not annotated:
        return steps
    candidate = list(steps)
    for index, step in enumerate(steps):
        note = annotated.get(step.name)
        if isinstance(step, Waypoint) and note is not None:
            try:
                offset = note["offset"]
                if not isinstance(offset, list):
                    raise TypeError("offset")
                candidate[index] = RelativeWaypoint(step.name, str(note["relative to"]), tuple(offset),
                                                    str(note.get("frame", "tool")), step.motion,
                                                    str(note.get("note", "")))
            except (KeyError, TypeError, ValueError):
                warnings.append(f"step {step.name!r}: its ur3dq note is not a relative waypoint's; imported as a "
                                "fixed waypoint")
    for _ in range(len(annotated) + 1):
        try:
            resolved = resolve_targets(candidate)
        except ValueError as error:
            culprit = next((i for i, s in enumerate(candidate) if f"'{s.name}'" in str(error)
                            and isinstance(s, RelativeWaypoint) and s.name in annotated), None)
            if culprit is None:
                raise
            warnings.append(f"{error}; imported as a fixed waypoint")
            candidate[culprit] = steps[culprit]
            continue
        moved = [i for i, (s, fixed) in enumerate(zip(candidate, steps)) if isinstance(s, RelativeWaypoint)
                 and s.name in annotated and isinstance(fixed, Waypoint)
                 and not _same_pose(resolved[s.name].pose, fixed.pose.dq)]
        if not moved:
            return candidate
        for i in moved:
            warnings.append(f"step {steps[i].name!r}: no longer where its base and offset put it (moved on the "
                            "pendant?); imported as a fixed waypoint")
            candidate[i] = steps[i]
    return steps


def _same_pose(a: DualQuaternion, b: DualQuaternion) -> bool:
    metres, radians = a.distance(b)
    return metres <= 1e-6 and radians <= 1e-6


def run_defaults_of(move: Element, children: list[Element]) -> bool:
    """True when the Move starts with ur3dq's note that its speed and acceleration are the run's defaults and
    still has those values (a Move edited on the pendant keeps its own)."""
    note = annotation_of(children[0]) if children else None
    values = note.get(RUN_DEFAULTS) if note else None
    if not isinstance(values, dict):
        return False
    try:
        return float(move.get("speed", "nan")) == values.get("speed") and \
            float(move.get("acceleration", "nan")) == values.get("acceleration")
    except ValueError:
        return False


def annotation_of(node: Element) -> dict[str, object] | None:
    """The JSON object of an `ur3dq: {...}` comment, or None for any other node."""
    if node.tag != "Comment":
        return None
    text = node.get("comment") or node.findtext("comment") or ""
    if not text.startswith(ANNOTATION + "{"):
        return None
    try:
        value = json.loads(text[len(ANNOTATION):])
    except ValueError:
        return None
    return value if isinstance(value, dict) else None
