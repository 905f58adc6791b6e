"""The motion watch's decisions from sequences of states and robot messages (pure: no controller needed)."""
import numpy as np
import pytest

from ur3dq.errors import ProgramError
from ur3dq.robot import primary, state
from ur3dq.robot.motion_watch import SETTLE_TIME, MotionWatch

TARGET = np.array([0.5, 0, 0, 0, 0, 0])


def status(q0, running, moving=False, age=0.0):
    speeds = np.array([0.3, 0, 0, 0, 0, 0]) if moving else np.zeros(6)
    return state.RobotStatus(np.array([q0, 0, 0, 0, 0, 0]), speeds, np.zeros(6), 7, 1, running, False, False, 1.0,
                             1.0, age)


def key(title, name="p"):
    return primary.KeyMessage(0, 0, title, name)


def watch(running_at_send=False):
    return MotionWatch("p", TARGET, running_at_send=running_at_send)


def test_done_when_the_program_ended_and_the_arm_rests_on_target():
    outcome = watch()
    assert not outcome.finished(status(0.0, running=False), 0.0)  # not started yet
    assert not outcome.finished(status(0.2, running=True, moving=True), 0.1)
    assert not outcome.finished(status(0.5, running=True), 0.2)  # still running
    assert outcome.finished(status(0.5, running=False), 0.21)


def test_the_stopped_key_message_ends_the_program_before_the_state_agrees():
    outcome = watch()
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    assert outcome.finished(status(0.5, running=True), 1.0)


def test_key_messages_of_other_programs_are_ignored():
    outcome = watch()
    outcome.note_message(key("PROGRAM_XXX_STOPPED", name="other"))
    assert not outcome.finished(status(0.5, running=True), 1.0)


def test_ending_off_target_is_a_program_error_after_the_settle_time():
    outcome = watch()
    outcome.finished(status(0.2, running=True, moving=True), 0.0)
    assert not outcome.finished(status(0.3, running=False), 0.1)
    with pytest.raises(ProgramError, match="0.2000 rad from its target: C4A1: joint limit"):
        outcome.note_message(primary.ErrorCodeMessage(4, 1, 3, "joint limit"))
        outcome.finished(status(0.3, running=False), 0.1 + SETTLE_TIME + 0.01)


def test_a_state_from_before_the_end_does_not_say_where_the_arm_ended():
    """A flaky run: the state stream froze (garbage on 30002) just before a move ended on target; the frozen state
    showed the arm 0.84 rad short, and the watch called it a program that ended off target. Only a state delivered
    after the end may; until one comes the stream's freeze check (Robot._checked_status) has the last word."""
    outcome = watch()
    outcome.finished(status(0.2, running=True, moving=True), 0.0)
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    for now in (0.1, 0.1 + SETTLE_TIME + 0.01, 1.4):   # the same state, delivered at 0.0 and ageing
        assert not outcome.finished(status(0.2, running=True, moving=True, age=now), now)
    with pytest.raises(ProgramError, match="0.3000 rad from its target"):
        outcome.finished(status(0.2, running=False, age=0.05), 1.5)   # delivered at 1.45, after the end


def test_a_stale_running_flag_of_the_previous_program_is_not_our_start():
    outcome = watch(running_at_send=True)
    outcome.finished(status(0.0, running=True), 0.0)
    assert not outcome.started
    outcome.finished(status(0.0, running=False), 0.01)  # the previous program's flag clears
    assert not outcome.finished(status(0.0, running=False), 0.01 + SETTLE_TIME + 0.1)  # ours not started: wait
    outcome.finished(status(0.1, running=True, moving=True), 1.0)
    assert outcome.started


def test_a_runtime_exception_is_raised_after_the_settle_time():
    outcome = watch()
    outcome.note_message(primary.RuntimeExceptionMessage(2, 3, "compile_error_name_not_found:x:"))
    assert not outcome.finished(status(0.0, running=False), 0.0)
    with pytest.raises(ProgramError, match="line 2, column 3: compile_error"):
        outcome.finished(status(0.0, running=False), SETTLE_TIME + 0.01)


def test_at_rest_on_target_after_the_start_message_is_not_the_end():
    """Issue 14 item 1: a closed path [B, A] from A starts at its target; the started key message arrives before
    the state shows the program running, so "at rest on target" then only means the arm has not left yet."""
    outcome = watch()
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    assert not outcome.finished(status(0.5, running=False), 0.0)   # at the target, program not yet on the stream
    assert not outcome.finished(status(0.3, running=True, moving=True), 0.5)
    assert not outcome.finished(status(0.5, running=True), 1.0)
    assert outcome.finished(status(0.5, running=False), 1.01)    # seen running, then not: it ended


def test_at_rest_on_target_without_any_evidence_of_the_program_is_not_the_end():
    outcome = watch()
    for tick in range(20):
        assert not outcome.finished(status(0.5, running=False), tick * SETTLE_TIME)
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    assert outcome.finished(status(0.5, running=False), 30.0)


class _Beats:
    """A heartbeat that went `gap` s without a write during the motion (ur3dq.robot.heartbeat.Heartbeat's
    longest_gap)."""

    def __init__(self, gap):
        self.gap = gap

    def longest_gap(self):
        return self.gap


@pytest.mark.parametrize("gap, named", [(0.143, True), (0.03, False)])
def test_a_stop_after_a_heartbeat_gap_names_the_heartbeat_watchdog(gap, named):
    """The controller's key message does not say why a program stopped; a heartbeat that went a watchdog period
    without a write is the likely cause (the flaky runs: gaps of 114-155 ms in a starved test process)."""
    outcome = MotionWatch("p", TARGET, running_at_send=False, heartbeat=_Beats(gap))
    outcome.finished(status(0.2, running=True, moving=True), 0.0)
    outcome.finished(status(0.3, running=False), 0.1)
    with pytest.raises(ProgramError) as caught:
        outcome.finished(status(0.3, running=False), 0.1 + SETTLE_TIME + 0.01)
    assert str(caught.value).endswith("heartbeat wrote nothing for 0.143 s; the watchdog stops a program after "
                                      "0.1 s): this computer was too busy to keep the heartbeat; end what loads "
                                      "it, then go on") == named
    assert ("heartbeat watchdog" in str(caught.value)) == named


def test_a_program_another_client_started_after_ours_is_named_as_the_cause():
    outcome = watch()
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    outcome.finished(status(0.2, running=True, moving=True), 0.0)
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    outcome.note_message(key("PROGRAM_XXX_STARTED", name="other"))
    assert not outcome.finished(status(0.3, running=True), 0.1)
    with pytest.raises(ProgramError, match="0.2000 rad from its target: another client replaced it with its own "
                                           "program 'other'"):
        outcome.finished(status(0.3, running=True), 0.1 + SETTLE_TIME + 0.01)


def test_a_stop_without_error_or_heartbeat_gap_says_another_client_may_have_stopped_it():
    outcome = MotionWatch("p", TARGET, running_at_send=False, heartbeat=_Beats(0.02))
    outcome.finished(status(0.2, running=True, moving=True), 0.0)
    outcome.finished(status(0.3, running=False), 0.1)
    with pytest.raises(ProgramError, match="stopped it without an error, as when another client stops the program"):
        outcome.finished(status(0.3, running=False), 0.1 + SETTLE_TIME + 0.01)
