"""Commands from the server → autopilot actions, each command uid run exactly once.

Delivery is at least once (docs/api.md): a command is offered on every poll until the boat acks
it, and again after a restart if the ack had not gone out. So every uid is recorded in the
outbox database *before* it runs (:meth:`Outbox.command_claim`) and a uid seen before is never
run again. A command that was running when the client died cannot be resumed safely; at the
next start it is acked ``failed`` with that reason.

Acks go into the outbox (they survive an outage like fixes do): ``acknowledged`` when the
autopilot has accepted the command, then ``done`` or ``failed`` with a reason a person can read,
or ``superseded`` when a newer navigation command (or a disarm) replaced it before it ended.

Kind → action (docs/edge-client.md#commands for the Rover modes):
``move_to`` GUIDED + SET_POSITION_TARGET_GLOBAL_INT, done within the acceptance radius;
``hold`` HOLD; ``resume`` AUTO; ``return_home`` RTL, done within the acceptance radius of home
(or when Rover says "Reached destination" and holds there); ``set_mode``; ``arm``/``disarm``;
``mission`` upload (home as item 0, :func:`edge_client.mission.build_mission`) then
MISSION_SET_CURRENT 1 and AUTO; by its ``end``: ``stop`` is done when Rover reports the last
waypoint reached (after its hold), ``return_home`` when the final NAV_RETURN_TO_LAUNCH has
brought it home (as ``return_home`` sees it, but in AUTO), ``loop`` once running;
``fence`` loads the vessel's fence set into the autopilot, reads it back and switches it on
(:mod:`edge_client.fence_upload`), replacing no running command. Commands that make the boat
move arm it first when it is disarmed (``arm_before_move``), waiting out pre-arm checks.
A command polled before the autopilot's first HEARTBEAT (the Pi and the server can be quicker
than the autopilot after a power-up) waits for it, and a mode that needs a position is
asked for again while the autopilot is still getting one and until its EKF failsafe clears
(a second later on Rover); each wait lasts at most ``ready_timeout_s``
(:meth:`Executor._wait_for_autopilot`, :meth:`Executor._mode_when_ready`).

The parameter checks (:func:`edge_client.commands.validate`, offered here too) are pure and
tested on their own.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from edge_client.commands import Command, CommandError, parse_command, validate
from edge_client.config import CommandsConfig
from edge_client.contract.backoff import doubled
from edge_client.contract.catalog import NAVIGATION_KINDS
from edge_client.contract.kinds import ROVER_POSITION_MODES
from edge_client.contract.status import Status
from edge_client.fence_upload import upload_fence
from edge_client.mavlink_link import HOME_POSITION_ID, LinkDown, MavlinkLink
from edge_client.mission import (
    FIRST_ITEM,
    MAV_CMD_NAV_WAYPOINT,
    MissionError,
    MissionItem,
    WaypointNumbers,
    build_mission,
    result_name,
)
from edge_client.outbox import Outbox
from edge_client.vehicle import CLOCK_SANE_AFTER, VehicleState

log = logging.getLogger(__name__)

# The ack statuses the boat reports (the contract's names).
ACKNOWLEDGED, DONE, FAILED = Status.ACKNOWLEDGED, Status.DONE, Status.FAILED
SUPERSEDED = Status.SUPERSEDED  # replaced here by a newer command before it ended
# Modes in which Rover drives by itself: entering one arms first (when allowed).
MOVING_MODES = frozenset({"AUTO", "GUIDED", "RTL", "SMART_RTL", "LOITER"})
POSITION_MODES = ROVER_POSITION_MODES  # refused until the EKF has a position
MODE_RETRY_S = 2.0  # between looks at the vehicle's reports while it gets its position
# A refusal once the position is good is asked again after 0.5, 1, 2, 2 … s: Rover reports its
# position about a second before its EKF failsafe clears (Rover/ekf_check.cpp counts 10 good
# checks at 10 Hz), and refuses until then.
MODE_BACKOFF_FIRST_S = 0.5
MODE_BACKOFF_MAX_S = 2.0
PAUSE_STEP_S = 0.1  # how often a backoff looks whether the failsafe has cleared meanwhile
# How long after the position is first seen good a refusal may still be the start-up one when
# no "EKF failsafe" text was heard (it may have been sent before we listened): 5 x Rover's 1 s.
# Later, it has another reason (AUTO without a mission…), and the command fails with it.
MODE_SETTLE_S = 5.0
# COMMAND_ACK results that no waiting changes (common.xml MAV_RESULT): DENIED, UNSUPPORTED.
FINAL_REFUSALS = frozenset({2, 3})
HEARTBEAT_WAIT_S = 0.5  # between looks for the autopilot's HEARTBEAT
RTL_ARRIVED = "Reached destination"  # Rover/mode_rtl.cpp STATUSTEXT; a boat then loiters there
MISSION_COMPLETE = "Mission Complete"  # Rover/mode_auto.cpp exit_mission STATUSTEXT


def _failsafe_cleared(state: VehicleState) -> Callable[[], bool]:
    return lambda: not state.ekf_failsafe


@dataclass
class Active:
    """A command that was accepted and whose outcome is still to be seen."""

    command: Command
    check: Callable[[], tuple[str, str] | None]  # → (DONE|FAILED, detail) once decided


@dataclass
class ModeSeen:
    """Tracks whether the vehicle entered ``mode`` and has since left it.

    The mode is confirmed from HEARTBEAT, which can lag the COMMAND_ACK by up to a second;
    "left" only counts after the mode was seen once, so that lag is not taken for a change.
    """

    mode: str
    entered: bool = False

    def left(self, current: str | None) -> bool:
        if current == self.mode:
            self.entered = True
            return False
        return self.entered


class Executor:
    def __init__(
        self,
        link: MavlinkLink,
        outbox: Outbox,
        config: CommandsConfig,
        on_ack: Callable[[], None] | None = None,
        *,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], object] | None = None,
    ) -> None:
        self.link = link
        self.outbox = outbox
        self.config = config
        self.on_ack = on_ack  # wakes the uplink so acks go out promptly
        self.active: Active | None = None
        self.executed: list[str] = []  # uids run in this process, in order (for tests and logs)
        self._queue: queue.Queue[Command] = queue.Queue()
        self._known: set[str] = set()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.clock = clock  # for the ready_timeout_s deadline; tests inject their own
        self.sleep = sleep or self._stop.wait

    # -- lifecycle ----------------------------------------------------------------------------

    def recover(self) -> None:
        """Fail the commands that were running when the client last stopped (cannot resume)."""
        for uid, kind in self.outbox.commands_interrupted():
            log.warning("command %s (%s) was interrupted by a restart", uid, kind)
            self._ack(
                Command(uid, kind, {}),
                FAILED,
                "edge client restarted while the command was running",
            )
        self.outbox.commands_forget_old()

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="executor", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 10.0) -> None:
        self._stop.set()
        if self._thread:
            self._thread.join(timeout)

    def is_alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def offer(self, raw_commands: list[Any]) -> int:
        """Take the commands from a poll; queue those never seen before. Returns how many."""
        new = 0
        for raw in raw_commands:
            try:
                command = parse_command(raw)
            except CommandError as exc:
                log.warning("ignoring malformed command: %s", exc)
                continue
            new += self.offer_command(command)
        return new

    def offer_command(self, command: Command) -> bool:
        """Queue one command unless its uid was seen before, by any link (the poll, SBD).
        Two links offering the same uid at once are safe: only one claim is ever committed."""
        if command.uid in self._known:
            return False
        self._known.add(command.uid)
        # The claim is committed before the command runs: at most once, even across a crash.
        if not self.outbox.command_claim(command.uid, command.kind):
            log.debug("command %s already handled before; not running it again", command.uid)
            return False
        self._queue.put(command)
        return True

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                command = self._queue.get(timeout=0.2)
            except queue.Empty:
                self.watch()
                continue
            self.execute(command)
            self.watch()

    # -- running one command ------------------------------------------------------------------

    def execute(self, command: Command) -> None:
        """Run one claimed command; every path ends in an ack (or an Active to watch)."""
        log.info("command %s: %s %s", command.uid, command.kind, command.params)
        self.executed.append(command.uid)
        try:
            params = validate(command.kind, command.params)
            if command.expires_at and time.time() > CLOCK_SANE_AFTER:
                if datetime.now(UTC) > command.expires_at:
                    raise CommandError(f"expired at {command.expires_at.isoformat()} before it ran")
            if command.kind in NAVIGATION_KINDS or command.kind == "disarm":
                self._supersede(command)
            self._wait_for_autopilot()
            getattr(self, f"_do_{command.kind}")(command, params)
        except CommandError as exc:
            self._ack(command, FAILED, str(exc))
        except LinkDown as exc:
            self._ack(command, FAILED, f"autopilot not reachable: {exc}")
        except Exception as exc:  # a bug must not kill the executor thread
            log.exception("command %s crashed", command.uid)
            self._ack(command, FAILED, f"edge client error: {exc.__class__.__name__}: {exc}")

    def watch(self) -> None:
        """Decide the active command's outcome if it is known now."""
        active = self.active
        if active is None:
            return
        try:
            outcome = active.check()
        except Exception as exc:
            log.exception("watching %s failed", active.command.uid)
            outcome = (FAILED, f"edge client error: {exc}")
        if outcome is not None:
            self.active = None
            self._ack(active.command, *outcome)

    def _supersede(self, command: Command) -> None:
        if self.active is not None:
            old, self.active = self.active, None
            detail = f"replaced by {command.kind} command {command.uid}"
            self._ack(old.command, SUPERSEDED, detail)

    def _ack(self, command: Command, status: str, detail: str) -> None:
        log.info("command %s: %s %s", command.uid, status, detail)
        self.outbox.add_ack(command.uid, status, detail)
        if status != ACKNOWLEDGED:
            self.outbox.command_finish(command.uid)
        if self.on_ack:
            self.on_ack()

    def _wait_for_autopilot(self) -> None:
        """Wait up to ``ready_timeout_s`` for the autopilot to be heard (LinkDown after)."""
        state, timeout = self.link.state, self.config.ready_timeout_s
        deadline = self.clock() + timeout
        while state.system is None or not state.autopilot_ok():
            if self.clock() >= deadline or self._stop.is_set():
                raise LinkDown(f"no HEARTBEAT from the autopilot within {timeout:g} s")
            self.sleep(HEARTBEAT_WAIT_S)

    def _mode(self, name: str) -> str:
        if name in POSITION_MODES:
            return self._mode_when_ready(name)
        answer = self.link.set_mode(name)
        if not answer.ok:
            raise CommandError(answer.detail)
        return answer.detail

    def _mode_when_ready(self, name: str) -> str:
        """Enter a mode that needs a position, waiting out the autopilot's start-up.

        After boot Rover refuses such modes ("Flight mode change failed", COMMAND_ACK FAILED)
        until its EKF has a position, which can take a minute after the GPS fix, and then
        for about a second more, until its EKF failsafe clears; a command that arrives then
        must not be thrown away.

        1. Ask for the mode; accepted: done. Refused DENIED or UNSUPPORTED: no waiting
           changes that; fail now with the autopilot's words.
        2. While the vehicle's own reports (EKF_STATUS_REPORT, GPS_RAW_INT, SYS_STATUS,
           GPS_GLOBAL_ORIGIN/HOME_POSITION: :meth:`VehicleState.position_ready`) say "no
           position yet", look again each ``MODE_RETRY_S`` without asking (Rover is not
           nagged while it plainly cannot).
        3. Otherwise ask again after a short backoff (``MODE_BACKOFF_*``): while the EKF
           failsafe is on (the autopilot said so), while the reports say nothing either way,
           or for ``MODE_SETTLE_S`` after the position was first seen good. A refusal after
           that has another reason: fail now with it.
        4. At ``ready_timeout_s`` ask one last time, then fail with the autopilot's words: its
           COMMAND_ACK result, the STATUSTEXT that came with it, what we were waiting for and
           the latest other STATUSTEXT.
        """
        state = self.link.state
        timeout = self.config.ready_timeout_s
        deadline = self.clock() + timeout
        backoff = MODE_BACKOFF_FIRST_S
        settle_until: float | None = None
        while True:
            said = state.statustext_count
            answer = self.link.set_mode(name)
            if answer.ok:
                return answer.detail
            if answer.result in FINAL_REFUSALS:
                raise CommandError(answer.detail)
            ready, why = state.position_ready()
            if ready is not False and state.ekf_failsafe:
                why = "the autopilot's EKF failsafe has not cleared"
            now = self.clock()
            if now >= deadline:
                why = f"not ready after {timeout:g} s: {why}"
                raise CommandError(self._refusal(answer.detail, why, said))
            if self._stop.is_set():
                raise CommandError(f"{answer.detail}; edge client stopping: {why}")
            if ready is False:
                settle_until, backoff = None, MODE_BACKOFF_FIRST_S
                log.info("%s; waiting for a position estimate: %s", answer.detail, why)
                self._wait_for_position(deadline)
                continue
            if ready and not state.ekf_failsafe:
                settle_until = now + MODE_SETTLE_S if settle_until is None else settle_until
                if now >= settle_until:
                    why = f"still refused {MODE_SETTLE_S:g} s after the position was good ({why})"
                    raise CommandError(self._refusal(answer.detail, why, said))
            log.info("%s; asking again in %g s (%s)", answer.detail, backoff, why)
            # "EKF failsafe cleared" ends the pause at once: no need to wait out the backoff.
            cleared = _failsafe_cleared(state) if state.ekf_failsafe else (lambda: False)
            self._pause(min(backoff, max(0.0, deadline - now)), cleared)
            backoff = doubled(backoff, cap=MODE_BACKOFF_MAX_S)

    def _pause(self, seconds: float, until: Callable[[], bool]) -> None:
        """Sleep ``seconds`` in short steps, ending early once ``until()`` or on a stop."""
        end = self.clock() + seconds
        while (left := end - self.clock()) > 0 and not until() and not self._stop.is_set():
            self.sleep(min(PAUSE_STEP_S, left))

    def _wait_for_position(self, deadline: float) -> None:
        """Look at the vehicle's reports each MODE_RETRY_S until they no longer say "not
        ready", or until the deadline (or a stop): the caller then asks for the mode again."""
        while self.clock() < deadline and not self._stop.is_set():
            self.sleep(min(MODE_RETRY_S, max(0.0, deadline - self.clock())))
            if self.link.state.position_ready()[0] is not False:
                return

    def _refusal(self, detail: str, why: str, said: int) -> str:
        """A refusal in the autopilot's words, with what we waited for and the latest other
        thing it said (STATUSTEXT): "… FAILED (Flight mode change failed); <why>; the autopilot
        last said: EKF failsafe"."""
        state = self.link.state
        with_refusal = set(state.statustext_since(said))
        others = [t for t in state.statustext if t not in with_refusal]
        last = f"; the autopilot last said: {others[-1]}" if others else ""
        return f"{detail}; {why}{last}"

    def _ensure_armed(self) -> None:
        if self.link.state.armed:
            return
        if not self.config.arm_before_move:
            raise CommandError("vehicle is disarmed and arm_before_move is off")
        ok, detail = self.link.arm(self.config.arm_timeout_s, stop=self._stop)
        if not ok:
            raise CommandError(detail)

    # -- one method per kind ------------------------------------------------------------------

    def _do_move_to(self, command: Command, p: dict[str, Any]) -> None:
        self.link.target()  # fail fast with LinkDown before arming anything
        self._ensure_armed()
        self._mode("GUIDED")
        self.link.goto(p["lat"], p["lon"])
        radius = self.config.acceptance_radius_m
        self._ack(command, ACKNOWLEDGED, f"GUIDED to {p['lat']:.6f}, {p['lon']:.6f}")
        state = self.link.state

        seen = ModeSeen("GUIDED")

        def check() -> tuple[str, str] | None:
            distance = state.distance_to(p["lat"], p["lon"])
            if distance is not None and distance <= radius:
                return DONE, f"arrived within {distance:.1f} m (radius {radius:g} m)"
            if seen.left(state.mode):
                return FAILED, f"mode changed to {state.mode} before arriving"
            return None

        self.active = Active(command, check)

    def _simple_mode(self, command: Command, mode: str) -> None:
        self.link.target()
        if mode in MOVING_MODES:
            self._ensure_armed()
        detail = self._mode(mode)
        self._ack(command, ACKNOWLEDGED, detail)
        self._ack(command, DONE, detail)

    def _do_hold(self, command: Command, p: dict[str, Any]) -> None:
        self._simple_mode(command, "HOLD")

    def _do_resume(self, command: Command, p: dict[str, Any]) -> None:
        self._simple_mode(command, "AUTO")

    def _do_return_home(self, command: Command, p: dict[str, Any]) -> None:
        self.link.target()
        self._ensure_armed()
        self._ask_for_home()
        detail = self._mode("RTL")
        arrived = self._home_watch("RTL", self.link.state.statustext_count)
        self._ack(command, ACKNOWLEDGED, detail)
        self.active = Active(command, arrived)

    def _ask_for_home(self) -> None:
        if self.link.state.home is None:
            self.link.request_message(HOME_POSITION_ID)  # its answer sets state.home

    def _home_watch(
        self, mode: str, said: int, returning: Callable[[], bool] = lambda: True
    ) -> Callable[[], tuple[str, str] | None]:
        """A check that the boat, returning home in ``mode``, got there.

        Done within ``acceptance_radius_m`` of home (once ``returning()`` says the return is
        under way: a mission may start at home), or when Rover says "Reached destination"
        after ``said`` (the STATUSTEXT count when the return was asked for: an older arrival
        is not ours) while still in ``mode``. Failed when the mode changes first.
        """
        state = self.link.state
        radius = self.config.acceptance_radius_m
        seen = ModeSeen(mode)

        def check() -> tuple[str, str] | None:
            nonlocal said
            home = state.home
            distance = state.distance_to(*home) if home else None
            if distance is not None and distance <= radius and returning():
                return DONE, f"home: arrived within {distance:.1f} m (radius {radius:g} m)"
            # Count first: a text landing in between is seen twice rather than never.
            count = state.statustext_count
            heard, said = state.statustext_since(said), count
            if RTL_ARRIVED in heard and state.mode == mode:
                # Rover's RTL may end at a rally point, or home may still be unknown to us.
                return DONE, "the autopilot reports it reached home and holds there"
            if seen.left(state.mode):
                return FAILED, f"mode changed to {state.mode} before reaching home"
            return None

        return check

    def _do_set_mode(self, command: Command, p: dict[str, Any]) -> None:
        self._simple_mode(command, p["mode"])

    def _do_arm(self, command: Command, p: dict[str, Any]) -> None:
        self.link.target()
        ok, detail = self.link.arm(self.config.arm_timeout_s, stop=self._stop)
        if not ok:
            raise CommandError(detail)
        self._ack(command, ACKNOWLEDGED, detail)
        self._ack(command, DONE, detail)

    def _do_disarm(self, command: Command, p: dict[str, Any]) -> None:
        ok, detail = self.link.disarm()
        if not ok:
            raise CommandError(detail)
        self._ack(command, ACKNOWLEDGED, detail)
        self._ack(command, DONE, detail)

    def _do_fence(self, command: Command, p: dict[str, Any]) -> None:
        self.link.target()
        accepted = lambda detail: self._ack(command, ACKNOWLEDGED, detail)  # noqa: E731
        self._ack(command, DONE, upload_fence(self.link, p["fences"], accepted))

    def _do_mission(self, command: Command, p: dict[str, Any]) -> None:
        state = self.link.state
        self.link.target()
        # Item 0 is home for ArduPilot; it keeps its own home, so any sane position will do.
        home = state.home or ((state.lat, state.lon) if state.lat is not None else (0.0, 0.0))
        try:
            items = build_mission(home, p["items"], end=p["end"])
        except MissionError as exc:
            raise CommandError(str(exc)) from None
        upload = self.link.upload_mission(items)
        if not upload.ok:
            raise CommandError(f"mission upload failed: {upload.error}")
        # The fixes' waypoint readings count in the operator's numbers from now on.
        state.waypoints = WaypointNumbers.of(items)
        self._ack(
            command,
            ACKNOWLEDGED,
            f"{len(p['items'])} waypoints accepted ({result_name(upload.result)})",
        )
        self._ensure_armed()
        if p["end"] == "return_home":
            self._ask_for_home()
        # Forget the last mission's progress: only what this one reports counts.
        state.last_reached = state.mission_seq = None
        self.link.set_mission_current(FIRST_ITEM)
        self._mode("AUTO")
        said = state.statustext_count  # after the mode change: older texts are not this mission's
        if p["end"] == "loop":
            self._ack(command, DONE, "looping mission running in AUTO")
            return
        if p["end"] == "return_home":
            watch = self._mission_home_watch(items, said)
        else:
            watch = self._mission_end_watch(items, p["items"][-1], said)
        self.active = Active(command, self._with_progress(command, items, watch))

    def _with_progress(
        self,
        command: Command,
        items: list[MissionItem],
        check: Callable[[], tuple[str, str] | None],
    ) -> Callable[[], tuple[str, str] | None]:
        """``check``, logging each item Rover reports done in the operator's numbers
        ("reached waypoint 3 of 5"), not MAVLink's (which count home and speed changes)."""
        state, numbers = self.link.state, WaypointNumbers.of(items)
        logged: int | None = None

        def progress() -> tuple[str, str] | None:
            nonlocal logged
            reached = state.last_reached
            if reached is not None and reached != logged and numbers.number(reached):
                logged = reached
                log.info("command %s: reached %s", command.uid, numbers.describe(reached))
            return check()

        return progress

    def _mission_end_watch(
        self, items: list[MissionItem], end: dict[str, Any], said: int
    ) -> Callable[[], tuple[str, str] | None]:
        """Done when Rover reports the last waypoint reached: MISSION_ITEM_REACHED, which it
        sends once the waypoint's hold is over (Rover/mode_auto.cpp
        ``verify_command_callback``), or its "Mission Complete" if that message was lost.
        Rover then stops and stays in AUTO (MIS_DONE_BEHAVE 0); leaving AUTO first fails."""
        state = self.link.state
        last = max(i.seq for i in items if i.command == MAV_CMD_NAV_WAYPOINT)
        numbers = WaypointNumbers.of(items)
        complete = f"mission complete ({numbers.count} of {numbers.count})"
        radius = max(self.config.acceptance_radius_m, end["radius_m"])
        seen = ModeSeen("AUTO")

        def check() -> tuple[str, str] | None:
            nonlocal said
            if state.last_reached == last:
                return DONE, complete
            count = state.statustext_count
            heard, said = state.statustext_since(said), count
            if MISSION_COMPLETE in heard and state.mode == "AUTO":
                return DONE, f"{complete}: the autopilot says so"
            if seen.left(state.mode):
                # Someone changed the mode; if it was right at the end, the mission is done.
                near = state.distance_to(end["lat"], end["lon"])
                if state.mission_seq == last and near is not None and near <= radius:
                    return DONE, f"{complete}: {near:.1f} m from the last waypoint"
                where = numbers.describe(state.mission_seq)
                return FAILED, f"mode changed to {state.mode} on the way to {where}"
            return None

        return check

    def _mission_home_watch(
        self, items: list[MissionItem], said: int
    ) -> Callable[[], tuple[str, str] | None]:
        """Done when the final NAV_RETURN_TO_LAUNCH has brought the boat home.

        Rover runs it inside AUTO (Rover/mode_auto.cpp ``start_RTL``: the RTL sub-mode, the
        mode stays AUTO), says "Reached destination" on arrival and then sends
        MISSION_ITEM_REACHED for the RTL item. The position check of :meth:`_home_watch`
        counts only once the RTL item is the current one (the boat may start at home).
        """
        state = self.link.state
        rtl = items[-1].seq
        count = WaypointNumbers.of(items).count
        home_reached = self._home_watch("AUTO", said, lambda: state.mission_seq == rtl)

        def check() -> tuple[str, str] | None:
            if state.last_reached == rtl:
                return DONE, f"mission complete ({count} of {count}), home reached"
            outcome = home_reached()
            if outcome is not None and outcome[0] == DONE:
                return DONE, f"mission complete ({count} of {count}), {outcome[1]}"
            return outcome

        return check
