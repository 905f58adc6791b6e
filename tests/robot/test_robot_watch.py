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


def test_the_stopped_key_message_ends_the_program_once_the_state_agrees():
    """The key message comes a state cycle before the state stream shows the program ended: a caller reading the
    state right after the motion returned found it still running."""
    outcome = watch()
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    outcome.finished(status(0.4, running=True, moving=True), 0.9)
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    assert not outcome.finished(status(0.5, running=True), 1.0)
    assert outcome.finished(status(0.5, running=False), 1.008)


def test_a_state_that_never_shows_the_program_ended_is_a_program_error():
    outcome = MotionWatch("p", TARGET, running_at_send=False, state_lag=0.5)
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    assert not outcome.finished(status(0.5, running=True), 1.0)
    assert not outcome.finished(status(0.5, running=True), 1.49)
    with pytest.raises(ProgramError, match="program p ended, but the controller's state still showed a program "
                                           "running 0.5 s after its end"):
        outcome.finished(status(0.5, running=True), 1.51)


def test_a_program_shorter_than_a_state_cycle_ends_on_a_state_delivered_after_its_end():
    """A program that ran less than a state cycle (a zero-length move): the state it ends on must come after its
    end, or one still on its way may show it running when the caller reads the state next."""
    outcome = watch()
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    assert not outcome.finished(status(0.5, running=False, age=0.007), 1.0)   # delivered before its start
    assert not outcome.finished(status(0.5, running=True), 1.005)   # the one state that caught it running
    assert outcome.finished(status(0.5, running=False), 1.013)


def test_a_late_start_message_of_an_earlier_program_is_no_replacement():
    """The previous motion ended on the state's evidence before its key messages came: they arrive in this
    watch's queue before this program's own, and are no program started after it."""
    outcome = watch()
    outcome.finished(status(0.4, running=True, moving=True), 0.0)
    outcome.note_message(key("PROGRAM_XXX_STARTED", name="earlier"))
    outcome.note_message(key("PROGRAM_XXX_STOPPED", name="earlier"))
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    assert outcome.replaced_by is None
    assert not outcome.finished(status(0.5, running=True), 0.1)   # still this program, on the state


def test_a_frozen_state_showing_the_program_running_is_left_to_the_freeze_check():
    """A stream that froze before the end delivers no state after it: the wait for the state to agree raises
    nothing of its own, and the stream's freeze check (Robot._checked_status) keeps its bound."""
    outcome = watch()
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    for now in (1.0, 2.01, 2.4):   # the same state, delivered at 1.0, ageing past the state_lag of 1 s
        assert not outcome.finished(status(0.5, running=True, age=now - 1.0), now)


def test_an_ended_program_waiting_for_the_state_is_no_motion_timeout():
    """Ended on its key message, the state stalled before it showed the end: the stream's freeze check names that,
    not a motion that did not finish."""
    outcome = watch()
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    outcome.check_progress(status(0.4, running=True, moving=True), 0.1, 0.1, 5.0, 1.0, "")
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    assert not outcome.finished(status(0.5, running=True, age=0.9), 1.0)
    outcome.check_progress(status(0.5, running=True, age=1.1), 1.2, 1.2, 5.0, 1.0, "")


def test_another_clients_program_running_after_ours_ended_on_target_is_not_waited_for():
    outcome = watch()
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    outcome.finished(status(0.4, running=True, moving=True), 0.9)
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))
    assert not outcome.finished(status(0.5, running=True), 1.0)   # its start not reported yet: still ours
    outcome.note_message(key("PROGRAM_XXX_STARTED", name="other"))
    assert outcome.finished(status(0.5, running=True), 1.01)


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
    assert not outcome.finished(status(0.5, running=False), 30.0)   # the state may be from before its start
    assert outcome.finished(status(0.5, running=False), 30.01)   # this one came after its end


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


def test_ending_at_rest_on_target_without_its_last_report_waits_for_its_end_message_then_fails():
    """A program with step reports (reported_end) that ends at rest on its target before its last report: its
    reports may still be on their way until its STOPPED key message, which follows them, has come; after that it
    was stopped short, a ProgramError (no timeout counts any more: waiting on would be forever)."""
    reported = []
    outcome = MotionWatch("p", TARGET, running_at_send=False, reported_end=lambda: bool(reported))
    outcome.note_message(key("PROGRAM_XXX_STARTED"))
    outcome.finished(status(0.5, running=True, moving=True), 0.5)
    assert not outcome.finished(status(0.5, running=False), 1.0)     # ended on the state: the reports may come
    assert outcome.finished(status(0.5, running=False), 1.01) is False
    reported.append(True)                                           # they came: done
    assert outcome.finished(status(0.5, running=False), 1.02)
    reported.clear()
    outcome.note_message(key("PROGRAM_XXX_STOPPED"))                # its end, and still no last report
    with pytest.raises(ProgramError, match="ended before it reported its last step, with the arm at rest where the "
                                           "program ends: the controller stopped it without an error"):
        outcome.finished(status(0.5, running=False), 1.03)
