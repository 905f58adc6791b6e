"""No command that writes a file may write to the pose store, its lock or any file the store owns, however the
output path names it (relative, absolute, through a symlink or a hard link): one error line, exit 3, and every
file of the store's directory byte-identical."""
import os
from pathlib import Path

import pytest

from cli_support import assert_one_line_error
from test_cli_offline import CONFIGS, thesis_lines_of
from ur3dq.store import store_file_role

# Every command that writes a file to a path the user names, with its output option.
WRITERS = {
    "export-urscript": lambda path: ["export-urscript", "-o", path, "--yes"],
    "export-urp": lambda path: ["export-urp", "-o", path, "--yes"],
    "plot": lambda path: ["plot", "-o", path, "--yes"],
    "poses export": lambda path: ["poses", "export", path, "--yes"],
    "poses export json": lambda path: ["poses", "export", path, "--format", "json", "--yes"],
    "demo --save": lambda path: ["demo", "--save", path],
}


@pytest.fixture
def program_store(tmp_path, run_in_process):
    """A version-2 store (a cell program) in `tmp_path`, with the version-1 backup its upgrade kept."""
    (tmp_path / "cell.txt").write_text(thesis_lines_of(CONFIGS))
    assert run_in_process("poses", "import", "cell.txt").returncode == 0
    assert run_in_process("poses", "add-step", "wait", "0.5").returncode == 0
    assert (tmp_path / "poses.json.v1.bak").exists()
    return tmp_path / "poses.json"


def snapshot(directory):
    """{name: bytes} of every file in `directory` (symlinks read through)."""
    return {entry.name: entry.read_bytes() for entry in sorted(directory.iterdir()) if entry.is_file()}


def owned_names(tmp_path):
    """Paths naming the store or a file it owns, each in another way; created here where a link is needed."""
    (tmp_path / "sub").mkdir()
    os.symlink("poses.json", tmp_path / "link.json")
    os.link(tmp_path / "poses.json", tmp_path / "hard.json")
    os.symlink(tmp_path, tmp_path / "here")
    return ["poses.json", "./sub/../poses.json", str(tmp_path / "poses.json"), "link.json", "hard.json",
            "here/poses.json", "poses.json.lock", "poses.json.v1.bak", "poses.json.v1.bak.3",
            "poses.json.resume", ".poses.json.k2x9q1ab.tmp", ".poses.json.resume.k2x9q1ab.tmp"]


@pytest.mark.parametrize("writer", WRITERS)
def test_no_writing_command_touches_a_file_the_store_owns(tmp_path, run_in_process, program_store, writer):
    names = owned_names(tmp_path)
    before = snapshot(tmp_path)
    for name in names:
        result = run_in_process(*WRITERS[writer](name))
        assert_one_line_error(result, 3, str(Path(name)), "pose store")
        assert snapshot(tmp_path) == before, (writer, name)


def test_a_store_reached_through_a_symlink_owns_its_target_and_its_lock(tmp_path, run_in_process):
    (tmp_path / "real").mkdir()
    (tmp_path / "cell.txt").write_text(thesis_lines_of(CONFIGS))
    os.symlink("real/poses.json", tmp_path / "link.json")
    assert run_in_process("--store", "link.json", "poses", "import", "cell.txt").returncode == 0
    before = snapshot(tmp_path / "real")
    for name in ("real/poses.json", "real/poses.json.lock", "link.json"):
        for writer in ("export-urscript", "poses export"):
            result = run_in_process("--store", "link.json", *WRITERS[writer](name))
            assert_one_line_error(result, 3, "pose store")
    assert snapshot(tmp_path / "real") == before


def test_other_outputs_are_still_written(tmp_path, run_in_process, program_store):
    for name in ("cell.script", "poses.json.script", "poses.json.v1.bakery", "other/../poses.jsonl"):
        (tmp_path / "other").mkdir(exist_ok=True)
        assert run_in_process("export-urscript", "-o", name, "--yes").returncode == 0, name
        assert (tmp_path / name).read_text().startswith("#")


def test_store_file_role_names_each_owned_file(tmp_path):
    store = tmp_path / "poses.json"
    store.write_text("{}")
    assert store_file_role(store, tmp_path / "poses.json") == "the pose store itself"
    assert store_file_role(store, tmp_path / "poses.json.lock") == "the pose store's lock file"
    assert store_file_role(store, tmp_path / "poses.json.v1.bak.12") == "the pose store's version-1 backup"
    assert store_file_role(store, tmp_path / ".poses.json.v1.bak.abcdefgh.tmp") == "a temporary file of the pose store"
    assert store_file_role(store, tmp_path / "poses.json.resume") == "the pose store's resume state"
    assert store_file_role(store, tmp_path / "x" / "poses.json") is None
    assert store_file_role(store, tmp_path / "poses.json.txt") is None
