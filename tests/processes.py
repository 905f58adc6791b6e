"""Processes as /proc shows them (Linux)."""
import os


def children_of(pid):
    """The pids of the living processes whose parent is `pid` (from /proc)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat", "rb") as stat_file:
                    stat = stat_file.read()
            except OSError:   # it ended meanwhile
                continue
            state, parent = stat[stat.rfind(b")") + 2:].split()[:2]
            if int(parent) == pid and state != b"Z":
                found.append(int(entry))
    return found
