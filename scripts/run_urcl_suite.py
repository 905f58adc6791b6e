#!/usr/bin/env python3
"""Run Universal_Robots_Client_Library's integration suite against sim_ursim and print the pass/fail/skip table.

URCL is built outside this repository (with ``-DBUILDING_TESTS=1 -DINTEGRATION_TESTS=1``); this script only runs
it, case by case as ctest does: the cases and their arguments come from ``ctest --show-only=json-v1`` in the build
directory, each case is its own process in the case's working directory, ``--robot_ip`` points at the simulator
(the ``_urcap`` cases keep their ``--headless false``). One simulator serves the whole run, as one URSim serves
URCL's CI, configured as that URSim is (``--remote-control off``: remote control not enabled). URCL's drivers
listen on ports 50001-50004 of every address and its fake primary server on 30001, so the run happens in a private
network namespace (``unshare -n``; it re-executes itself there), and each case whose fixture starts a fake server
gets a namespace of its own, without the simulator.

URCL's cases are timed against a real-time controller: a keep-alive written every 100 ms against a 200 ms receive
timeout, an RTDE package awaited 100 ms, a spline's first 8 ms cycle looked for in the stream. On a shared, loaded
machine an ordinary process can wait hundreds of milliseconds for a CPU, so by default (``--realtime``) the
simulator and every case run at the lowest real-time priority (``chrt --rr 1``; URCL raises its own RTDE reader to
FIFO 99 itself), as a controller runs its loop and as URCL's real-time guide sets up the client's machine.
``--no-realtime`` runs them as ordinary processes. ``--busy N`` starts N busy processes (``python3 -c 'while True:
pass'``) beside them for the whole run: a controlled load on a 2-core machine. Each case's line
gives the simulator's CPU share meanwhile (CPU seconds of its process per wall second).

URCL up to ``c5d1e26`` (2.14.0) has a defect in its test harness that fails RTDEClientTest's four fake-server
cases on some builds: its fake RTDE server passes an uninitialised byte count to ``TCPServer::writeUnchecked``,
which sends from that offset. UR fixed it in URCL PR #573 (``written = 0;`` at the top of ``writeUnchecked``);
build a URCL that has it (docs/client-compatibility.md).

Not part of the test suite or CI (it needs the outside build). Usage::

    scripts/run_urcl_suite.py URCL_BUILD_DIR --model ur5 --version 3.14.3
    scripts/run_urcl_suite.py URCL_BUILD_DIR --model ur5e --version 5.9.4 --filter 'DashboardClient'
    scripts/run_urcl_suite.py URCL_BUILD_DIR --filter '^$' --example dashboard_example   # an example alone

Exit status: 0 when no case failed, 1 when one did, 2 for a usage or setup problem.
"""
import argparse
import contextlib
import json
import os
import re
import shlex
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

# The executables URCL's tests/CMakeLists.txt registers under INTEGRATION_TESTS (the others are unit tests).
INTEGRATION_EXECUTABLES = (
    "rtde_tests", "dashboard_client_g5_tests", "dashboard_client_x_tests", "spline_tests_urcap",
    "spline_tests_headless", "ur_driver_tests_urcap", "ur_driver_tests_headless",
    "external_control_program_tests_urcap", "external_control_program_tests_headless",
    "trajectory_streaming_tests_headless", "instruction_executor_test_urcap", "instruction_executor_test_headless",
    "primary_client_test_headless", "ur_driver_deprecated_constructor_test",
)
# Cases that listen on a UR port (30001, 30004) of every address, which the simulator's own sockets would block: they
# run in a namespace of their own (they talk to their fake server on 127.0.0.1, not to the simulator).
OWN_NAMESPACE = re.compile(r"^PrimaryClientFakeTest\.|^RTDEClientTest\.test_initialization$|fake_server")
NAMESPACE_MARK = "RUN_URCL_SUITE_IN_NAMESPACE"
REPOSITORY = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Case:
    """One ctest case: its name, command line and working directory."""

    name: str
    command: tuple[str, ...]
    directory: str

    @property
    def executable(self) -> str:
        return Path(self.command[0]).name

    @property
    def needs_own_namespace(self) -> bool:
        """Cases that start a fake UR server run without the simulator (OWN_NAMESPACE)."""
        return OWN_NAMESPACE.search(self.name) is not None


@dataclass(frozen=True)
class Outcome:
    case: Case
    verdict: str  # PASS, FAIL or SKIP
    seconds: float
    simulator_cpu: float = float("nan")  # CPU seconds of the simulator's process per wall second of the case


def parse_arguments(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("build", type=Path, help="URCL's build directory (built with its integration tests)")
    parser.add_argument("--model", default="ur5", help="sim-ursim --model (default ur5)")
    parser.add_argument("--version", default="3.14.3", help="sim-ursim --version (default 3.14.3)")
    parser.add_argument("--host", default="127.0.0.2", help="loopback address of the simulator (default 127.0.0.2)")
    parser.add_argument("--programs-dir", type=Path, default=None,
                        help="default: URCL's tests/resources/dockerursim/programs/{cb3,e-series}")
    parser.add_argument("--filter", default=None, help="only cases whose name matches this regular expression")
    parser.add_argument("--example", action="append", default=[],
                        help="also run this URCL example (build/examples/NAME ROBOT_IP) after the cases; repeatable")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per case (default 600)")
    parser.add_argument("--logs", type=Path, default=None, help="directory for each case's output and the sim's log")
    parser.add_argument("--realtime", action=argparse.BooleanOptionalAction, default=True,
                        help="run the simulator and the cases at real-time priority `chrt --rr 1` (default: on)")
    parser.add_argument("--busy", type=int, default=0, metavar="N",
                        help="run N busy processes (python3 -c 'while True: pass') beside the run (default 0)")
    parser.add_argument("--python", default=str(REPOSITORY / ".venv" / "bin" / "python"),
                        help="interpreter that runs sim_ursim (default: the repository's .venv)")
    return parser.parse_args(argv)


def reexecute_in_namespace(argv: list[str]) -> int:
    """Run this script again inside a private network namespace with its loopback up."""
    inner = " ".join(shlex.quote(part) for part in [sys.executable, str(Path(__file__).resolve()), *argv])
    environment = dict(os.environ, **{NAMESPACE_MARK: "1"})
    try:
        return subprocess.call(["unshare", "-n", "sh", "-c", f"ip link set lo up && exec {inner}"], env=environment)
    except FileNotFoundError:
        print("run_urcl_suite: `unshare` not found (util-linux); it is needed for a private network namespace",
              file=sys.stderr)
        return 2


def integration_cases(build: Path) -> list[Case]:
    """The integration cases ctest knows in `build`, in ctest's order."""
    listing = subprocess.run(["ctest", "--show-only=json-v1"], cwd=build, capture_output=True, text=True, check=True)
    cases = []
    for test in json.loads(listing.stdout)["tests"]:
        command = test.get("command")
        if not command or Path(command[0]).name not in INTEGRATION_EXECUTABLES:
            continue
        directory = next((p["value"] for p in test.get("properties", []) if p["name"] == "WORKING_DIRECTORY"),
                         str(build))
        cases.append(Case(test["name"], tuple(command), directory))
    return cases


def example_cases(build: Path, names: list[str]) -> list[Case]:
    """URCL examples run like cases: `build/examples/NAME` with the robot's address (added by run_case)."""
    return [Case(f"example.{name}", (str(build / "examples" / name),), str(build)) for name in names]


def default_programs_dir(build: Path, model: str) -> Path:
    series = "e-series" if model.endswith("e") else "cb3"
    return build.resolve().parent / "tests" / "resources" / "dockerursim" / "programs" / series


def wait_for_port(host: str, port: int, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with socket.create_connection((host, port), timeout=0.5):
                return True
        except OSError:
            time.sleep(0.1)
    return False


REALTIME = ("chrt", "--rr", "1")


def realtime_prefix(wanted: bool) -> tuple[str, ...]:
    """`chrt --rr 1` when real-time priority is wanted and allowed here, else nothing (with a note why)."""
    if not wanted:
        return ()
    try:
        allowed = subprocess.run([*REALTIME, "true"], capture_output=True).returncode == 0
    except FileNotFoundError:
        allowed = False
    if not allowed:
        print("run_urcl_suite: real-time priority is not available (`chrt --rr 1` failed: needs CAP_SYS_NICE); "
              "running as ordinary processes", file=sys.stderr)
        return ()
    return REALTIME


CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def process_cpu_seconds(pid: int) -> float:
    """User + system CPU seconds a process (all its threads) has used so far (nan once it is gone)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as handle:
            fields = handle.read().rsplit(")", 1)[1].split()
    except OSError:
        return float("nan")
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


@contextlib.contextmanager
def busy_processes(count: int) -> Iterator[None]:
    """`count` processes that each spin on a core until the block ends (killed then)."""
    spinners = [subprocess.Popen(["python3", "-c", "while True: pass"]) for _ in range(count)]
    try:
        yield
    finally:
        for spinner in spinners:
            spinner.kill()
            spinner.wait()


def start_simulator(options: argparse.Namespace, programs: Path, log_path: Path,
                    prefix: tuple[str, ...] = ()) -> "subprocess.Popen[bytes]":
    command = [*prefix, options.python, "-m", "sim_ursim", "--model", options.model, "--version", options.version,
               "--host", options.host, "--programs-dir", str(programs), "--remote-control", "off"]
    log = open(log_path, "w", encoding="utf-8")
    simulator = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, cwd=REPOSITORY)
    if not wait_for_port(options.host, 30004, 30.0):
        simulator.terminate()
        raise RuntimeError(f"the simulator did not serve {options.host}:30004 within 30 s (log: {log_path})")
    return simulator


def verdict_of(returncode: int, output: str) -> str:
    """PASS, FAIL or SKIP from a gtest run of one case (ctest also counts a skipped case as not failed)."""
    if returncode != 0:
        return "FAIL"
    if re.search(r"^\[  SKIPPED \] 1 test", output, re.MULTILINE):
        return "SKIP"
    return "PASS"


def run_case(case: Case, host: str, timeout: float, log_dir: Path, prefix: tuple[str, ...] = (),
             simulator_pid: int | None = None) -> Outcome:
    command = [*case.command, host] if case.name.startswith("example.") else [*case.command, "--robot_ip", host]
    if case.needs_own_namespace:
        inner = " ".join(shlex.quote(part) for part in command)
        command = ["unshare", "-n", "sh", "-c", f"ip link set lo up && exec {inner}"]
    command = [*prefix, *command]
    began = time.monotonic()
    cpu_before = process_cpu_seconds(simulator_pid) if simulator_pid else float("nan")
    try:
        finished = subprocess.run(command, cwd=case.directory, capture_output=True, text=True, timeout=timeout,
                                  errors="replace")
        returncode, output = finished.returncode, finished.stdout + finished.stderr
    except subprocess.TimeoutExpired as expired:
        returncode = -1
        parts = [part.decode(errors="replace") if isinstance(part, bytes) else part or ""
                 for part in (expired.stdout, expired.stderr)]
        output = "".join(parts) + f"\n*** timed out after {timeout:.0f} s\n"
    seconds = time.monotonic() - began
    cpu = (process_cpu_seconds(simulator_pid) - cpu_before) / seconds if simulator_pid else float("nan")
    (log_dir / f"{case.name}.log").write_text(output, encoding="utf-8")
    return Outcome(case, verdict_of(returncode, output), seconds, cpu)


def print_table(outcomes: list[Outcome], title: str) -> None:
    groups: dict[str, dict[str, int]] = {}
    for outcome in outcomes:
        counts = groups.setdefault(outcome.case.executable, {"PASS": 0, "FAIL": 0, "SKIP": 0})
        counts[outcome.verdict] += 1
    print(f"\n{title}")
    print(f"{'executable':42} {'pass':>5} {'fail':>5} {'skip':>5}")
    totals = {"PASS": 0, "FAIL": 0, "SKIP": 0}
    for executable, counts in groups.items():
        print(f"{executable:42} {counts['PASS']:5d} {counts['FAIL']:5d} {counts['SKIP']:5d}")
        for verdict, count in counts.items():
            totals[verdict] += count
    print(f"{'total (' + str(len(outcomes)) + ' cases)':42} {totals['PASS']:5d} {totals['FAIL']:5d} "
          f"{totals['SKIP']:5d}")
    failed = [o for o in outcomes if o.verdict == "FAIL"]
    if failed:
        print("\nfailed:")
        for outcome in failed:
            print(f"  {outcome.case.name}  ({outcome.seconds:.1f} s)")


def run_cases(cases: list[Case], options: argparse.Namespace, programs: Path, log_dir: Path,
              prefix: tuple[str, ...]) -> list[Outcome]:
    """Run `cases` one after the other against one simulator; stops early if the simulator exits."""
    simulator = start_simulator(options, programs, log_dir / "sim_ursim.log", prefix)
    outcomes = []
    try:
        for number, case in enumerate(cases, 1):
            outcome = run_case(case, options.host, options.timeout, log_dir, prefix, simulator.pid)
            outcomes.append(outcome)
            print(f"[{number:3d}/{len(cases)}] {outcome.verdict} {case.name} ({outcome.seconds:.1f} s, simulator "
                  f"CPU {outcome.simulator_cpu:.0%})", flush=True)
            if simulator.poll() is not None:
                print(f"run_urcl_suite: the simulator exited ({simulator.returncode}); see its log", file=sys.stderr)
                break
    finally:
        simulator.terminate()
        try:
            simulator.wait(10)
        except subprocess.TimeoutExpired:  # a starved simulator may not finish its shutdown in time
            simulator.kill()
            simulator.wait()
    return outcomes


def run_suite(options: argparse.Namespace) -> int:
    build = options.build.resolve()
    cases = integration_cases(build)
    if options.filter:
        cases = [case for case in cases if re.search(options.filter, case.name)]
    cases += example_cases(build, options.example)
    if not cases:
        print("run_urcl_suite: no integration case found (was URCL built with -DINTEGRATION_TESTS=1?)",
              file=sys.stderr)
        return 2
    programs = (options.programs_dir or default_programs_dir(build, options.model)).resolve()
    log_dir = (options.logs or Path(f"urcl-suite-{options.model}-{time.strftime('%Y%m%d-%H%M%S')}")).resolve()
    log_dir.mkdir(parents=True, exist_ok=True)
    prefix = realtime_prefix(options.realtime)
    load_before = os.getloadavg()[0]
    with busy_processes(options.busy):
        outcomes = run_cases(cases, options, programs, log_dir, prefix)
    priority = "real-time (chrt --rr 1)" if prefix else "ordinary priority"
    busy = f", {options.busy} busy processes beside it" if options.busy else ""
    print_table(outcomes, f"URCL integration suite against sim_ursim {options.model} {options.version}, {priority}"
                          f"{busy}, load average {load_before:.1f} -> {os.getloadavg()[0]:.1f} (logs: {log_dir})")
    return 1 if any(o.verdict == "FAIL" for o in outcomes) or len(outcomes) < len(cases) else 0


def main(argv: list[str]) -> int:
    options = parse_arguments(argv)
    if os.environ.get(NAMESPACE_MARK) != "1":
        return reexecute_in_namespace(argv)
    try:
        return run_suite(options)
    except (RuntimeError, subprocess.CalledProcessError, OSError) as error:
        print(f"run_urcl_suite: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
