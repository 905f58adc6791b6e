"""The page's edits of the program, each one locked, atomic store update (PoseStore.update_program, as the CLI's
`poses` commands make), with undo and redo of the last MAX_UNDO of them.

An edit is a pure function steps -> (new steps, result). Undo puts back the program as it was before an edit only
if the store still holds what that edit wrote (compared as the store's own text of the steps): a change made
meanwhile by the CLI or another page is never lost, the undo is refused instead, naming why.

Example
-------
>>> from ur3dq.program.steps import Wait
>>> steps, added = insert_step(lambda taken: Wait("settle", 0.5), None)([])   # an edit is a pure function
>>> [step.name for step in steps]
['settle']
>>> editor = ProgramEditor(PoseStore("poses.json"))              # doctest: +SKIP
>>> editor.apply("delete 'via'", delete_step("via"))               # doctest: +SKIP
>>> editor.undo()                                                 # doctest: +SKIP
"""
from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable
from typing import Any

from ur3dq.errors import StoreError
from ur3dq.pose import Pose
from ur3dq.program.steps import Motion, Step, Waypoint, is_waypoint
from ur3dq.store import PoseStore, find_step, renamed_steps, with_added
from ur3dq.store_format import format_program_v2

MAX_UNDO = 50
#: An edit: the program's steps -> (the new steps, what the edit made: the new step, the stored poses, or None).
Edit = Callable[[list[Step]], tuple[list[Step], Any]]


@dataclasses.dataclass(frozen=True)
class _Done:
    description: str
    before: list[Step]
    after_text: str


def program_text(steps: list[Step]) -> str:
    """The store's text of `steps` (what decides whether two programs are the same)."""
    return format_program_v2(steps)


class ProgramEditor:
    """Edits of the program in `store` with undo/redo (this page server's edits, the last MAX_UNDO)."""

    def __init__(self, store: PoseStore):
        self.store = store
        self._undo: list[_Done] = []
        self._redo: list[_Done] = []
        self._lock = threading.Lock()

    def state(self) -> dict[str, bool | str]:
        """{'can_undo', 'can_redo', 'undo_text', 'redo_text'} for the page's buttons."""
        with self._lock:
            return {"can_undo": bool(self._undo), "can_redo": bool(self._redo),
                    "undo_text": self._undo[-1].description if self._undo else "",
                    "redo_text": self._redo[-1].description if self._redo else ""}

    def apply(self, description: str, edit: Edit) -> Any:
        """Apply `edit` to the store (checked, locked, atomic) and remember it for undo; returns its result."""
        recorded: dict[str, list[Step]] = {}

        def remembering(steps: list[Step]) -> tuple[list[Step], Any]:
            new, result = edit(list(steps))
            recorded["before"], recorded["after"] = list(steps), list(new)
            return new, result

        with self._lock:
            result: Any = self.store.update_program(remembering)
            self._undo.append(_Done(description, recorded["before"], program_text(recorded["after"])))
            del self._undo[:-MAX_UNDO]
            self._redo.clear()
        return result

    def undo(self) -> str:
        """Put back the program as it was before the last edit; returns what was undone. StoreError if there is
        nothing to undo, or the program changed since that edit."""
        return self._swap(self._undo, self._redo, "undo")

    def redo(self) -> str:
        """Apply again the last undone edit; returns what was redone. StoreError as for undo."""
        return self._swap(self._redo, self._undo, "redo")

    def _swap(self, source: list[_Done], target: list[_Done], verb: str) -> str:
        with self._lock:
            if not source:
                raise StoreError(f"nothing to {verb}")
            done = source[-1]

            def restore(steps: list[Step]) -> tuple[list[Step], list[Step]]:
                if program_text(steps) != done.after_text:
                    raise StoreError(f"cannot {verb} {done.description!r}: the program was changed since (by the "
                                     f"command line or another page); {verb} would lose that change")
                return done.before, list(steps)

            now: list[Step] = self.store.update_program(restore)
            source.pop()
            target.append(_Done(done.description, now, program_text(done.before)))
            del target[:-MAX_UNDO]
            return done.description


# ---------------------------------------------------------------- the edits (pure: steps -> (steps, result))


def position_after(steps: list[Step], after: str | None) -> int:
    """Where a new step goes: just after the step `after`, or at the end."""
    if after is None:
        return len(steps)
    return [step.name for step in steps].index(find_step(steps, after, "the program").name) + 1


def insert_step(make: Callable[[set[str]], Step], after: str | None) -> Edit:
    """Insert the step make(taken names) just after `after` (or at the end); its name must be free."""

    def edit(steps: list[Step]) -> tuple[list[Step], Any]:
        taken = {step.name for step in steps}
        step = make(taken)
        if step.name in taken:
            raise StoreError(f"a step named {step.name!r} already exists")
        at = position_after(steps, after)
        return steps[:at] + [step] + steps[at:], step

    return edit


def record_pose(pose: Pose, after: str | None) -> Edit:
    """Store `pose` as a joint waypoint just after `after` (or at the end); a taken name is refused."""

    def edit(steps: list[Step]) -> tuple[list[Step], Any]:
        return with_added(steps, [pose], False, position=position_after(steps, after))

    return edit


def retouch(name: str, pose: Pose) -> Edit:
    """Re-record the waypoint `name` at `pose`, keeping its motion and place (relative waypoints follow it)."""

    def edit(steps: list[Step]) -> tuple[list[Step], Any]:
        step = find_step(steps, name, "the program")
        if not isinstance(step, Waypoint):
            raise ValueError(f"{step.who}: only a recorded waypoint can be re-recorded")
        return [Waypoint(name, pose, step.motion) if s is step else s for s in steps], None

    return edit


def set_motion(name: str, new: Callable[[Motion], Motion]) -> Edit:
    """Give the waypoint `name` the motion new(its motion now): the caller keeps what it does not change (the
    page's editor keeps the acceleration it does not show)."""

    def edit(steps: list[Step]) -> tuple[list[Step], Any]:
        step = find_step(steps, name, "the program")
        if not is_waypoint(step):
            raise ValueError(f"{step.who}: not a waypoint; only waypoints have a move, speed and blend")
        motion = new(step.motion)
        return [dataclasses.replace(s, motion=motion) if s is step else s for s in steps], None

    return edit


def move_step(name: str, offset: int) -> Edit:
    """Move the step `name` `offset` places (−1 up, +1 down)."""

    def edit(steps: list[Step]) -> tuple[list[Step], Any]:
        index = steps.index(find_step(steps, name, "the program"))
        to = index + offset
        if not 0 <= to < len(steps):
            raise ValueError(f"step {name!r} is already the {'first' if offset < 0 else 'last'}")
        moved = list(steps)
        moved.insert(to, moved.pop(index))
        return moved, None

    return edit


def delete_step(name: str) -> Edit:
    """Delete the step `name` (refused while a relative waypoint is based on it: the store's check)."""

    def edit(steps: list[Step]) -> tuple[list[Step], Any]:
        doomed = find_step(steps, name, "the program")
        return [step for step in steps if step is not doomed], None

    return edit


def rename_step(old: str, new: str) -> Edit:
    """Call the step `old` `new`; relative waypoints based on it follow."""

    def edit(steps: list[Step]) -> tuple[list[Step], Any]:
        find_step(steps, old, "the program")
        if new != old and any(step.name == new for step in steps):
            raise StoreError(f"a step named {new!r} already exists")
        return renamed_steps(steps, old, new), None

    return edit
