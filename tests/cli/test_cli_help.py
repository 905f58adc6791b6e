"""The help a new user reads: `ur3dq --help` fits 80 columns with every command's summary whole and grouped, every
command has help, and export-urscript says what it writes besides the moves."""
import click
from click.testing import CliRunner

from ur3dq.cli import cli
from ur3dq.cli.app import COMMAND_SECTIONS


def every_command(group=cli, path=()):
    for name, command in sorted(group.commands.items()):
        yield (*path, name), command
        if isinstance(command, click.Group):
            yield from every_command(command, (*path, name))


def test_the_top_help_fits_80_columns_with_every_summary_whole_and_grouped():
    text = CliRunner().invoke(cli, ["--help"], env={"COLUMNS": "80"}).output
    assert max(len(line) for line in text.splitlines()) <= 80
    commands = text[text.index("\nTeach and run:"):]
    assert "..." not in commands and "…" not in commands
    for title, _ in COMMAND_SECTIONS:
        assert f"\n{title}:\n" in text
    listing = " ".join(text.split())   # a summary may wrap; its words must all be there, in order
    for name, command in cli.commands.items():
        assert f"{name} {' '.join(command.short_help.split())}" in listing, name


def test_every_command_has_help_and_a_whole_summary():
    missing = [" ".join(path) for path, command in every_command() if not (command.help or "").strip()]
    assert not missing
    for path, command in every_command():
        summary = command.get_short_help_str(200)
        assert summary and not summary.endswith("..."), path


def test_export_urscript_says_what_it_writes_and_names_its_programs():
    text = " ".join(CliRunner().invoke(cli, ["export-urscript", "--help"], env={"COLUMNS": "80"}).output.split())
    assert "register 22" in text and "def ur3dq_program()" in text and "def ur3dq_poses()" in text
