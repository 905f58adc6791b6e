"""The pose store: a JSON file of recorded poses or a cell program (schema versions 1 and 2 in
docs/store-schema.md), crash-proof and shared safely.

Parsing and formatting (pure functions on text) live in ur3dq/store_format.py, apart from the file transport here
(`PoseStore`). Every write holds an inter-process lock (`<store>.lock`, filelock) across read-modify-write, and
replaces the file atomically: temporary file in the same directory, fsync, rename over the store, fsync the
directory. A crash at any moment leaves either the old or the new file, never a mix. A store that does not parse is
never overwritten; a store that is a symlink is written through the link; temporaries of killed writers are
removed by the next write.
"""
from __future__ import annotations

import dataclasses
import functools
import os
import re
import tempfile
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, TypeVar

from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import StoreError
from ur3dq.json_text import read_utf8
from ur3dq.pose import Pose, next_free_name, numbering_prefix, utc_now_iso
from ur3dq.program.resolve import check_program
from ur3dq.program.steps import RelativeWaypoint, Step, Waypoint
from ur3dq.store_format import (  # noqa: F401  (re-exported: the store's public names)
    PROGRAM_SCHEMA_VERSION,
    SCHEMA_NAME,
    SCHEMA_VERSION,
    format_program,
    format_program_v2,
    format_store,
    needs_version_2,
    own_layout_version,
    parse_document,
    parse_store,
    pose_from_dict,
    pose_to_dict,
)

LOCK_TIMEOUT_S = 30.0
DEFAULT_STORE_PATH = "poses.json"
#: `<store>` + this beside the store (of a symlink's target): what a stopped run keeps for `run-poses --resume`.
RESUME_SUFFIX = ".resume"

# ---------------------------------------------------------------- pure: thesis text lines <-> dual quaternions


_Result = TypeVar("_Result")


def parse_thesis_lines(text: str, source: str) -> list[tuple[int, DualQuaternion]]:
    """The poses of thesis text lines, with their line numbers.

    (line number, pose) for each thesis line `q.w q.x q.y q.z 0 p.x p.y p.z`; blank lines and `#` comments are
    skipped; StoreError `source:line` for a line that is not 8 numbers or not a rigid transform."""
    poses = []
    for number, line in enumerate(text.splitlines(), start=1):
        content = line.split("#", 1)[0].strip()
        if not content:
            continue
        try:
            poses.append((number, DualQuaternion.from_thesis_line(content)))
        except ValueError as error:
            raise StoreError(f"{source}:{number}: not a thesis pose line (8 numbers q.w q.x q.y q.z 0 p.x p.y p.z): "
                             f"{error}") from None
    return poses


def format_thesis_lines(poses: Iterable[DualQuaternion]) -> str:
    """The thesis text file: one `q.w q.x q.y q.z 0 p.x p.y p.z` line per pose."""
    return "".join(pose.to_thesis_line() + "\n" for pose in poses)


# ---------------------------------------------------------------- pure: edits of a program


def with_added(steps: list[Step], new: Iterable[Pose], number_if_taken: bool,
               position: int | None = None) -> tuple[list[Step], list[Pose]]:
    """The step list with `poses` added as joint waypoints.

    (the whole new step list, the poses as added): each pose becomes a joint waypoint (inserted at `position`,
    else appended); a taken name is an error, or gets the next free `-N` name."""
    result = list(steps)
    added = []
    at = len(result) if position is None else position
    for pose in new:
        taken = {existing.name for existing in result}
        if pose.name in taken:
            if not number_if_taken:
                raise StoreError(f"a pose named {pose.name!r} already exists; choose another name or remove it first")
            pose = pose.renamed(next_free_name(numbering_prefix(pose.name), taken))
        result.insert(at, Waypoint(pose.name, pose))
        at += 1
        added.append(pose)
    return result, added


def with_added_steps(steps: list[Step], new: Iterable[Step]) -> tuple[list[Step], list[Step], list[tuple[str, str]]]:
    """Another program's steps appended after `steps` (what `poses import` of a store file does).

    Returns (the whole new step list, the steps as added, [(name in `new`, name as added)] of those renamed): every
    step of `new` is kept as it is (move types, speeds, blends, relative waypoints, actions), a name already in
    `steps` gets the next free `-N` name, and the relative waypoints of `new` follow their base's new name.

    >>> from ur3dq.program.steps import Wait
    >>> result, added, renamed = with_added_steps([Wait("settle", 1.0)], [Wait("settle", 2.0)])
    >>> [step.name for step in result], renamed
    (['settle', 'settle-1'], [('settle', 'settle-1')])
    """
    new = list(new)
    existing = {step.name for step in steps}
    taken = existing | {step.name for step in new}
    renamed = []
    for name in [step.name for step in new if step.name in existing]:
        free = next_free_name(numbering_prefix(name), taken)
        taken.add(free)
        new = renamed_steps(new, name, free)
        renamed.append((name, free))
    return list(steps) + new, new, renamed


def find_step(steps: Sequence[Step], name: str, source: str) -> Step:
    """The step called `name`, or StoreError listing the names there are."""
    for step in steps:
        if step.name == name:
            return step
    known = ", ".join(repr(s.name) for s in steps[:10]) + (", ..." if len(steps) > 10 else "")
    raise StoreError(f"no pose named {name!r} in {source}" + (f" (it has {known})" if steps
                                                                      else " (it is empty)"))


def find_pose(poses: Sequence[Step], name: str, source: str) -> Pose:
    """The recorded pose called `name` (among Poses or steps), or StoreError listing the names there are."""
    found = find_step(poses, name, source)
    if isinstance(found, Waypoint):
        return found.pose
    if isinstance(found, Pose):
        return found
    raise StoreError(f"{name!r} in {source} is a {found.kind} step, not a recorded pose")


def renamed_steps(steps: list[Step], old: str, new: str) -> list[Step]:
    """`steps` with the step `old` called `new`, and relative waypoints based on `old` following it."""
    result = []
    for step in steps:
        if step.name == old:
            step = (Waypoint(new, step.pose.renamed(new), step.motion) if isinstance(step, Waypoint)
                    else dataclasses.replace(step, name=new))
        if isinstance(step, RelativeWaypoint) and step.base == old:
            step = dataclasses.replace(step, base=new)
        result.append(step)
    return result


# ---------------------------------------------------------------- transport: the file


def _fsync_directory(directory: Path) -> None:
    """Make a rename inside `directory` durable (POSIX: the directory entry lives in the directory's data)."""
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_atomically(path: Path, content: str | bytes) -> None:
    """Replace a file's content atomically.

    Replace `path` with `content` (text, or bytes): temp file in the same directory, fsync, rename over `path`,
    fsync the directory. A symlink is written through (its target is replaced, the link stays). StoreError naming
    `path` if it cannot be written; nothing is left behind then."""
    path = Path(os.path.realpath(path))
    directory = path.parent
    try:
        mode = path.stat().st_mode & 0o777 if path.exists() else 0o644
        fd, temporary = tempfile.mkstemp(dir=directory, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as error:
        raise StoreError(f"{path}: cannot write: {error.strerror or error}") from None
    try:
        with os.fdopen(fd, "wb") as stream:
            stream.write(content.encode("utf-8") if isinstance(content, str) else content)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, mode)
        os.replace(temporary, path)
        _fsync_directory(directory)
    except BaseException as error:
        if os.path.exists(temporary):
            os.unlink(temporary)
        if isinstance(error, OSError):
            raise StoreError(f"{path}: cannot write: {error.strerror or error}") from None
        raise


def _temporary_pattern(name: str) -> re.Pattern[str]:
    """The names of the temporaries written beside the store `name`, of it and of its upgrade backups."""
    return re.compile(r"^\." + re.escape(name) + r"(\.v1\.bak(\.[0-9]+)?)?\.[a-z0-9_]{8}\.tmp$")


def remove_orphan_temporaries(path: Path) -> int:
    """Delete the temporary files killed writers of a store left.

    Delete the temporary files killed writers of the store `path` left (`.<name>.XXXXXXXX.tmp`, and those of
    its upgrade backup `.<name>.v1.bak[.N].XXXXXXXX.tmp`); call it only while holding the store's lock, when no
    writer of this store can be mid-write. Returns how many went."""
    pattern = _temporary_pattern(path.name)
    removed = 0
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return 0
    for entry in entries:
        if pattern.match(entry.name) and entry.is_file(follow_symlinks=False):
            try:
                os.unlink(entry.path)
                removed += 1
            except OSError:
                pass  # another user's file, or gone already: not ours to insist on
    return removed


def _same_file(one: str | os.PathLike[str], other: str) -> bool:
    """True if both paths name one existing file (a hard link included)."""
    try:
        return os.path.samefile(one, other)
    except OSError:
        return False


def store_file_role(store_path: str | os.PathLike[str], candidate: str | os.PathLike[str]) -> str | None:
    """What `candidate` is to the pose store at `store_path`, or None when the store does not own it.

    The store owns its file, its lock `<store>.lock`, its version-1 backups `<store>.v1.bak[.N]`, the state a
    stopped run keeps for `run-poses --resume` (`<store>` + RESUME_SUFFIX) and the temporaries their writes
    leave beside them. Both paths are resolved first (symlinks, `..`), and an existing
    candidate that is the same file as one of those (a hard link) counts too. A command that writes a file calls
    this on its output first, so no output can replace the store or a file it relies on.

    Examples
    --------
    >>> store_file_role("poses.json", "./poses.json"), store_file_role("poses.json", "poses.json.lock")
    ('the pose store itself', "the pose store's lock file")
    >>> store_file_role("poses.json", "cell.script") is None
    True
    """
    store = os.path.realpath(store_path)
    target = os.path.realpath(candidate)
    name, directory = os.path.basename(store), os.path.dirname(store)
    owned = ((store, "the pose store itself"), (store + ".lock", "the pose store's lock file"),
             (store + RESUME_SUFFIX, "the pose store's resume state"))
    for path, role in owned:
        if target == path or _same_file(candidate, path):
            return role
    if os.path.dirname(target) != directory:
        return None
    entry = os.path.basename(target)
    if re.fullmatch(re.escape(name) + r"\.v1\.bak(\.[0-9]+)?", entry):
        return "the pose store's version-1 backup"
    if _temporary_pattern(name).match(entry) or _temporary_pattern(name + RESUME_SUFFIX).match(entry):
        return "a temporary file of the pose store"
    return None


def backup_path(path: Path) -> Path:
    """Where the version-1 copy of `path` goes on upgrade: `<path>.v1.bak`, or `.v1.bak.N` if that is taken."""
    candidate = path.with_name(path.name + ".v1.bak")
    number = 2
    while candidate.exists():
        candidate = path.with_name(f"{path.name}.v1.bak.{number}")
        number += 1
    return candidate


class PoseStore:
    """The JSON pose store at `path`: recorded poses or a cell program.

    A missing file is an empty store. A cell program is schema version 2 (docs/store-schema.md). Reads need no
    lock (writes are atomic renames); every write holds `<path>.lock` (of the link's target when `path` is a
    symlink) across read-modify-write.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from ur3dq.kinematics import robot_model
    >>> from ur3dq.pose import Pose
    >>> store = PoseStore(pathlib.Path(tempfile.mkdtemp()) / "poses.json")
    >>> pose = Pose.from_dual_quaternion("pick", robot_model("ur3").fk([0, -1.2, 1, -1.4, -1.57, 0]), "ur3")
    >>> store.add(pose).name, store.add(pose, number_if_taken=True).name
    ('pick', 'pick-1')
    >>> [p.name for p in store.load()]
    ['pick', 'pick-1']
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)

    @functools.cached_property
    def _lock(self) -> Any:
        """The inter-process write lock `<path>.lock` (of the link's target), made on the first write: filelock is
        imported only then (reads need no lock, and its import would slow every command's start)."""
        import filelock
        return filelock.FileLock(os.path.realpath(self.path) + ".lock", timeout=LOCK_TIMEOUT_S)

    def __repr__(self) -> str:
        return f"PoseStore({str(self.path)!r})"

    def _read(self) -> tuple[str | None, int | None, list[Step]]:
        """(file text or None, version or None, steps); ([], None) when the file does not exist yet."""
        try:
            text = read_utf8(self.path)
        except FileNotFoundError:
            return None, None, []
        except OSError as error:
            raise StoreError(f"{self.path}: cannot read the pose store: {error}") from None
        version, steps = parse_document(text, str(self.path))
        return text, version, steps

    def load_program(self) -> list[Step]:
        """Every step (Waypoint, RelativeWaypoint, actions), in program order; [] when there is no file yet."""
        return self._read()[2]

    def version(self) -> int | None:
        """The schema version of the file on disk (None when there is none).

        The schema version of the file on disk (None when it does not exist). A file in ur3dq's own layout is
        recognised from its first lines without parsing the rest (commands ask this before loading a big store);
        any other file is parsed (and must be valid)."""
        try:
            with open(self.path, "rb") as stream:
                head = stream.read(256).decode("utf-8", errors="replace")
        except FileNotFoundError:
            return None
        except OSError as error:
            raise StoreError(f"{self.path}: cannot read the pose store: {error}") from None
        version = own_layout_version(head)
        return version if version is not None else self._read()[1]

    def load(self) -> list[Pose]:
        """Every recorded pose, in program order; [] when the file does not exist yet."""
        return [step.pose for step in self.load_program() if isinstance(step, Waypoint)]

    def get(self, name: str) -> Pose:
        """The pose called `name`; StoreError naming the known poses if there is none."""
        return find_pose(self.load_program(), name, str(self.path))

    def get_step(self, name: str) -> Step:
        """The step (waypoint or action) called `name`; StoreError naming the known steps if there is none."""
        return find_step(self.load_program(), name, str(self.path))

    def select(self, names: Iterable[str] | None) -> list[Pose]:
        """The poses called `names`, in that order (all poses, in store order, when `names` is None or empty)."""
        names = list(names or [])
        if not names:
            return self.load()
        steps = self.load_program()
        return [find_pose(steps, name, str(self.path)) for name in names]

    def require_directory(self) -> None:
        """StoreError unless the store's directory exists (checked before work that would end in a write)."""
        if not Path(os.path.realpath(self.path)).parent.is_dir():
            raise StoreError(f"{self.path}: directory {self.path.parent} does not exist")

    def update_program(self, edit: Callable[[list[Step]], tuple[list[Step], _Result]]) -> _Result:
        """Apply `edit(steps) -> (new steps, result)` under the lock and write atomically; returns the result.

        The new program is checked first (ValueError naming the step; nothing written). It is written as version
        1 while it fits version 1 and the file is not version 2 already; the first version-2 write over a
        version-1 file keeps the old file as `<store>.v1.bak` (written, durably, before the store is replaced, so
        a kill at any moment leaves the old store or the new one with its backup)."""
        self.require_directory()
        target = Path(os.path.realpath(self.path))
        lock = self._lock
        from filelock import Timeout  # loaded with the lock (see _lock)
        try:
            with lock:
                remove_orphan_temporaries(target)
                text, version, steps = self._read()
                steps, result = edit(steps)
                check_program(steps)
                upgrade = version == SCHEMA_VERSION and needs_version_2(steps)
                if upgrade and text is not None:   # a version-1 file exists
                    write_atomically(backup_path(target), text)
                keep_version_2 = version == PROGRAM_SCHEMA_VERSION
                write_atomically(target, format_program_v2(steps) if keep_version_2 else format_program(steps))
        except Timeout:
            raise StoreError(f"{self.path}: another process has held the store's lock for {LOCK_TIMEOUT_S:.0f} s "
                             f"({lock.lock_file})") from None
        except OSError as error:
            raise StoreError(f"{self.path}: cannot write the pose store: {error}") from None
        return result

    def add(self, pose: Pose, number_if_taken: bool = False) -> Pose:
        """Store `pose`; return it as stored.

        Store `pose`; a taken name is an error, or (number_if_taken) becomes the next free `name-N`.
        Returns the pose as stored."""
        return self.add_many([pose], number_if_taken)[0]

    def add_many(self, poses: Iterable[Pose], number_if_taken: bool = False) -> list[Pose]:
        """Store several poses in one atomic write (all or none); returns them as stored."""
        new = list(poses)
        return self.update_program(lambda existing: with_added(existing, new, number_if_taken))

    def remove(self, name: str) -> Pose | Step:
        """Delete the pose or step called `name` and return it.

        Delete the pose or step called `name` and return it; StoreError if there is none, ValueError naming
        the relative waypoint still based on it."""

        def edit(steps: list[Step]) -> tuple[list[Step], Pose | Step]:
            doomed = find_step(steps, name, str(self.path))
            return [step for step in steps if step is not doomed], getattr(doomed, "pose", doomed)

        return self.update_program(edit)

    def rename(self, old: str, new: str) -> Pose | Step:
        """Rename a pose or step (relative waypoints based on it follow).

        Give the pose or step called `old` the name `new` (relative waypoints based on it follow); StoreError
        if `old` is missing or `new` is taken."""

        def edit(steps: list[Step]) -> tuple[list[Step], Pose | Step]:
            find_step(steps, old, str(self.path))
            if new != old and any(s.name == new for s in steps):
                raise StoreError(f"a pose named {new!r} already exists: choose another name, or remove it first")
            try:
                result = renamed_steps(steps, old, new)
            except ValueError as error:
                raise StoreError(str(error)) from None
            renamed = find_step(result, new, str(self.path))
            return result, getattr(renamed, "pose", renamed)

        return self.update_program(edit)

    def import_thesis_lines(self, file: str | os.PathLike[str], robot_model: str,
                            tcp_offset: Iterable[float] = (0.0,) * 6, prefix: str | None = None,
                            note: str = "") -> list[Pose]:
        """Add every pose of a thesis text file.

        Add every pose of a thesis text file (8 coefficients a line) as `prefix-N` (default prefix: the file's
        stem); no joints are known for them. All or nothing."""
        file = Path(file)
        try:
            text = read_utf8(file)
        except OSError as error:
            raise StoreError(f"{file}: cannot read: {error}") from None
        return self.add_thesis_text(text, file, robot_model, tcp_offset, prefix, note)

    def add_thesis_text(self, text: str, file: Path, robot_model: str, tcp_offset: Iterable[float] = (0.0,) * 6,
                        prefix: str | None = None, note: str = "") -> list[Pose]:
        """Add every pose of `text`, already read from the thesis text file `file`, as import_thesis_lines does."""
        entries = parse_thesis_lines(text, str(file))
        if not entries:
            raise StoreError(f"{file}: no pose lines found")
        stem = prefix or file.stem
        time = utc_now_iso()
        poses = [
            Pose.from_dual_quaternion(
                f"{stem}-{index}", pose, robot_model, tcp_offset=tuple(tcp_offset), time=time,
                note=note or f"imported from {file.name} line {line}",
            )
            for index, (line, pose) in enumerate(entries, start=1)
        ]
        return self.add_many(poses, number_if_taken=True)

    def export_thesis_lines(self, file: str | os.PathLike[str], names: Iterable[str] | None = None) -> int:
        """Write the poses (all, or those named) as thesis text lines to `file`, atomically; returns how many."""
        poses = self.select(names)
        file = Path(file)
        write_atomically(file, format_thesis_lines(pose.dq for pose in poses))
        return len(poses)
