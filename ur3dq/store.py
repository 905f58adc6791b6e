"""The pose store: a JSON file of recorded poses (schema in docs/store-schema.md), crash-proof and shared safely.

Parsing and formatting (pure functions on text) are kept apart from the file transport (`PoseStore`).
Every write holds an inter-process lock (`<store>.lock`, filelock) across read-modify-write, and replaces the file
atomically: temporary file in the same directory, fsync, rename over the store, fsync the directory. A crash at
any moment leaves either the old or the new file, never a mix. A store that does not parse is never overwritten.
"""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Callable, Iterable

import filelock

from ur3dq.dualquat import DualQuaternion
from ur3dq.errors import StoreError
from ur3dq.pose import Pose, next_free_name, numbering_prefix, utc_now_iso

SCHEMA_NAME = "ur3dq.poses"
SCHEMA_VERSION = 1
POSE_FIELDS = (
    "name", "time", "robot_model", "robot_serial", "joints", "dual_quaternion", "ur_pose", "tcp_offset", "note",
)
REQUIRED_POSE_FIELDS = ("name", "time", "robot_model", "dual_quaternion", "ur_pose")
LOCK_TIMEOUT_S = 30.0
DEFAULT_STORE_PATH = "poses.json"


# ---------------------------------------------------------------- pure: JSON text <-> poses


def pose_to_dict(pose: Pose) -> dict:
    """The JSON object of one pose, fields in schema order (lists of floats; joints null when unknown)."""
    return {
        "name": pose.name,
        "time": pose.time,
        "robot_model": pose.robot_model,
        "robot_serial": pose.robot_serial,
        "joints": list(pose.joints) if pose.joints is not None else None,
        "dual_quaternion": list(pose.dual_quaternion),
        "ur_pose": list(pose.ur_pose),
        "tcp_offset": list(pose.tcp_offset),
        "note": pose.note,
    }


def pose_from_dict(obj, who: str) -> Pose:
    """A Pose from its JSON object; ValueError naming `who` (e.g. "pose #3 'pick'") and the field at fault."""
    if not isinstance(obj, dict):
        raise ValueError(f"{who}: must be a JSON object, got {type(obj).__name__}")
    unknown = sorted(set(obj) - set(POSE_FIELDS))
    if unknown:
        raise ValueError(f"{who}: unknown field {unknown[0]!r} (known: {', '.join(POSE_FIELDS)})")
    missing = [field for field in REQUIRED_POSE_FIELDS if field not in obj]
    if missing:
        raise ValueError(f"{who}: missing field {missing[0]!r}")
    fields = dict(obj)
    fields["tcp_offset"] = fields.get("tcp_offset") if fields.get("tcp_offset") is not None else (0.0,) * 6
    fields["note"] = fields.get("note") or ""
    return Pose(**fields)


def format_store(poses: Iterable[Pose]) -> str:
    """The store file's text: the versioned envelope, one pose per line (so json's line numbers name a pose)."""
    lines = [json.dumps(pose_to_dict(pose), ensure_ascii=False) for pose in poses]
    body = ",\n    ".join(lines)
    poses_text = f"[\n    {body}\n  ]" if lines else "[]"
    return (
        "{\n"
        f'  "schema": {json.dumps(SCHEMA_NAME)},\n'
        f'  "version": {SCHEMA_VERSION},\n'
        f'  "poses": {poses_text}\n'
        "}\n"
    )


def _line_of_pose(text: str, name) -> int | None:
    """The 1-based line where the pose called `name` starts, when the file has the one-pose-per-line layout."""
    if not isinstance(name, str):
        return None
    needle = f'"name": {json.dumps(name, ensure_ascii=False)}'
    for number, line in enumerate(text.splitlines(), start=1):
        if needle in line:
            return number
    return None


def _where(text: str, source: str, name) -> str:
    """`source:line` of the pose called `name` when its line can be found, else `source` (only on errors: the
    search reads the whole text)."""
    line = _line_of_pose(text, name)
    return f"{source}:{line}" if line else source


def _without_pose_prefix(message: str, who: str, name) -> str:
    """`message` without the "pose ...: " it may already start with, so the caller names the pose once."""
    for prefix in (f"{who}: ", f"pose {name!r}: "):
        if message.startswith(prefix):
            return message[len(prefix):]
    return message


def parse_store(text: str, source: str) -> list[Pose]:
    """The poses in a store file's text; StoreError with `source:line` (where known) and what is wrong."""
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise StoreError(f"{source}:{error.lineno}:{error.colno}: not valid JSON: {error.msg}") from None
    if not isinstance(document, dict):
        raise StoreError(f"{source}:1: not a pose store: expected a JSON object with \"schema\": \"{SCHEMA_NAME}\"")
    if document.get("schema") != SCHEMA_NAME:
        raise StoreError(f"{source}:1: not a pose store: \"schema\" is {document.get('schema')!r}, "
                         f"expected {SCHEMA_NAME!r}")
    version = document.get("version")
    if version != SCHEMA_VERSION:
        newer = isinstance(version, int) and version > SCHEMA_VERSION
        raise StoreError(f"{source}:1: store version {version!r} is not supported (this ur3dq reads version "
                         f"{SCHEMA_VERSION}{'; the file was written by a newer ur3dq' if newer else ''})")
    entries = document.get("poses")
    if not isinstance(entries, list):
        raise StoreError(f"{source}:1: \"poses\" must be a list")
    poses: list[Pose] = []
    seen: set[str] = set()
    for index, entry in enumerate(entries, start=1):
        name = entry.get("name") if isinstance(entry, dict) else None
        who = f"pose #{index}" + (f" {name!r}" if isinstance(name, str) else "")
        try:
            pose = pose_from_dict(entry, who)
        except ValueError as error:
            where = _where(text, source, name)
            raise StoreError(f"{where}: {who}: {_without_pose_prefix(str(error), who, name)}") from None
        if pose.name in seen:
            raise StoreError(f"{_where(text, source, name)}: pose name {pose.name!r} appears twice")
        seen.add(pose.name)
        poses.append(pose)
    return poses


# ---------------------------------------------------------------- pure: thesis text lines <-> dual quaternions


def parse_thesis_lines(text: str, source: str) -> list[tuple[int, DualQuaternion]]:
    """(line number, pose) for each thesis line `q.w q.x q.y q.z 0 p.x p.y p.z`; blank lines and `#` comments are
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


# ---------------------------------------------------------------- pure: edits of a pose list


def with_added(poses: list[Pose], new: Iterable[Pose], number_if_taken: bool) -> tuple[list[Pose], list[Pose]]:
    """(the whole new list, the poses as added): duplicates are an error, or get the next free `-N` name."""
    result = list(poses)
    added = []
    for pose in new:
        taken = {existing.name for existing in result}
        if pose.name in taken:
            if not number_if_taken:
                raise StoreError(f"a pose named {pose.name!r} already exists; choose another name or remove it first")
            pose = pose.renamed(next_free_name(numbering_prefix(pose.name), taken))
        result.append(pose)
        added.append(pose)
    return result, added


def find_pose(poses: list[Pose], name: str, source: str) -> Pose:
    """The pose called `name`, or StoreError listing the names there are."""
    for pose in poses:
        if pose.name == name:
            return pose
    known = ", ".join(repr(p.name) for p in poses[:10]) + (", ..." if len(poses) > 10 else "")
    raise StoreError(f"no pose named {name!r} in {source}" + (f" (it has {known})" if poses else " (it is empty)"))


# ---------------------------------------------------------------- transport: the file


def _fsync_directory(directory: Path) -> None:
    """Make a rename inside `directory` durable (POSIX: the directory entry lives in the directory's data)."""
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_atomically(path: Path, text: str) -> None:
    """Replace `path` with `text`: temp file in the same directory, fsync, rename over `path`, fsync the directory."""
    directory = path.parent
    mode = path.stat().st_mode & 0o777 if path.exists() else 0o644
    fd, temporary = tempfile.mkstemp(dir=directory, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as stream:
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, mode)
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise
    _fsync_directory(directory)


class PoseStore:
    """The JSON pose store at `path` (missing file = empty store). Reads need no lock (writes are atomic renames);
    every write holds `<path>.lock` across read-modify-write."""

    def __init__(self, path):
        self.path = Path(path)
        self._lock = filelock.FileLock(str(self.path) + ".lock", timeout=LOCK_TIMEOUT_S)

    def __repr__(self):
        return f"PoseStore({str(self.path)!r})"

    def load(self) -> list[Pose]:
        """Every stored pose, in recording order; [] when the file does not exist yet."""
        try:
            text = self.path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return []
        except (OSError, UnicodeDecodeError) as error:
            raise StoreError(f"{self.path}: cannot read the pose store: {error}") from None
        return parse_store(text, str(self.path))

    def get(self, name: str) -> Pose:
        """The pose called `name`; StoreError naming the known poses if there is none."""
        return find_pose(self.load(), name, str(self.path))

    def select(self, names: Iterable[str] | None) -> list[Pose]:
        """The poses called `names`, in that order (all poses, in store order, when `names` is None or empty)."""
        poses = self.load()
        names = list(names or [])
        return [find_pose(poses, name, str(self.path)) for name in names] if names else poses

    def require_directory(self) -> None:
        """StoreError unless the store's directory exists (checked before work that would end in a write)."""
        if not self.path.parent.is_dir():
            raise StoreError(f"{self.path}: directory {self.path.parent} does not exist")

    def _update(self, edit: Callable[[list[Pose]], tuple[list[Pose], object]]):
        """Apply `edit(poses) -> (new poses, result)` under the lock and write atomically; returns the result."""
        self.require_directory()
        try:
            with self._lock:
                poses, result = edit(self.load())
                write_atomically(self.path, format_store(poses))
        except filelock.Timeout:
            raise StoreError(f"{self.path}: another process has held the store's lock for {LOCK_TIMEOUT_S:.0f} s "
                             f"({self._lock.lock_file})") from None
        except OSError as error:
            raise StoreError(f"{self.path}: cannot write the pose store: {error}") from None
        return result

    def add(self, pose: Pose, number_if_taken: bool = False) -> Pose:
        """Store `pose`; a taken name is an error, or (number_if_taken) becomes the next free `name-N`.
        Returns the pose as stored."""
        return self.add_many([pose], number_if_taken)[0]

    def add_many(self, poses: Iterable[Pose], number_if_taken: bool = False) -> list[Pose]:
        """Store several poses in one atomic write (all or none); returns them as stored."""
        new = list(poses)
        return self._update(lambda existing: with_added(existing, new, number_if_taken))

    def remove(self, name: str) -> Pose:
        """Delete the pose called `name` and return it; StoreError if there is none."""

        def edit(poses):
            doomed = find_pose(poses, name, str(self.path))
            return [pose for pose in poses if pose is not doomed], doomed

        return self._update(edit)

    def rename(self, old: str, new: str) -> Pose:
        """Give the pose called `old` the name `new`; StoreError if `old` is missing or `new` is taken."""

        def edit(poses):
            pose = find_pose(poses, old, str(self.path))
            if new != old and any(p.name == new for p in poses):
                raise StoreError(f"a pose named {new!r} already exists")
            try:
                renamed = pose.renamed(new)
            except ValueError as error:
                raise StoreError(str(error)) from None
            return [renamed if p is pose else p for p in poses], renamed

        return self._update(edit)

    def import_thesis_lines(self, file, robot_model: str, tcp_offset=(0.0,) * 6, prefix: str | None = None,
                            note: str = "") -> list[Pose]:
        """Add every pose of a thesis text file (8 coefficients a line) as `prefix-N` (default prefix: the file's
        stem); no joints are known for them. All or nothing."""
        file = Path(file)
        try:
            text = file.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as error:
            raise StoreError(f"{file}: cannot read: {error}") from None
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

    def export_thesis_lines(self, file, names: Iterable[str] | None = None) -> int:
        """Write the poses (all, or those named) as thesis text lines to `file`, atomically; returns how many."""
        poses = self.select(names)
        file = Path(file)
        try:
            write_atomically(file, format_thesis_lines(pose.dq for pose in poses))
        except OSError as error:
            raise StoreError(f"{file}: cannot write: {error}") from None
        return len(poses)
