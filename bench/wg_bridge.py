"""The whole Wave Glider bridge, timed: `python -m bench.wg_bridge` (issue 11, Speed).

In one process, on pseudo-terminals, against a throwaway SQLite database (or DATABASE_URL):

1. Level 2 reply latency: status requests written to the bridge's Level 2 pty, time to the
   first byte of the reply, while the modem is busy sending a backlog of replies (each +CMGS
   answered ``--send-delay`` s late). Next to it: the bare runner (the Level 2 library's
   PayloadRunner with its in-memory command source) on a pty in the same run.
2. SMS → C&C, with the C&C simulator polling every ``--period`` s in real time: the total from
   an SMS arriving at the modem to the inner command reaching the C&C, and the bridge's own
   part of it (SMS arrival → command queued in the database, plus request queued → its reply);
   next to the bare runner's request queued → reply.
3. The C&C's ACK → the reply SMS handed to the modem (``AT+CMGS`` typed); next to the bare
   runner's ACK → its notification (the earliest anything could react).

Targets (issue 11): 2. one poll period + ≤ 50 ms of the bridge's own time; 3. ≤ 100 ms;
1. median ≤ 5 ms, p99 ≤ 20 ms. Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import logging
import os
import select
import statistics
import sys
import tempfile
import threading
import time
from collections.abc import Callable

from sms.level2.simulator import QUEUED_DELAY_S
from sms.modem.simulator import SimulatedModem  # no Django

PERIOD_S = 1
SAMPLES = 1_000
ROUNDS = 8
SEND_DELAY_S = 0.2
BACKLOG = 40  # replies waiting for the busy modem during the latency run
NUMBER = "+61400000001"


def percentile(values: list[float], fraction: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(fraction * len(ordered)))]


def show(label: str, values_ms: list[float], baseline_ms: list[float]) -> None:
    def fmt(values: list[float]) -> str:
        if not values:
            return "no samples"
        return (
            f"median {statistics.median(values):7.2f} ms  p99 {percentile(values, 0.99):7.2f} ms"
            f"  (n={len(values)})"
        )

    print(f"  {label}")
    print(f"    bridge       {fmt(values_ms)}")
    print(f"    bare runner  {fmt(baseline_ms)}")


def level2_latency(fd_port: object, samples: int, spacing_s: float = 0.0) -> list[float]:
    """Status requests on a pty master; ms to the first byte of each reply."""
    from sms.level2.bodies import StatusRequest
    from sms.level2.codec import CC_MAIN, Address, Frame, MessageType

    fd = fd_port.fileno()  # type: ignore[attr-defined]
    body = bytes(StatusRequest())
    out: list[float] = []
    tid = 0x100
    for i in range(samples + 20):
        tid = (tid + 1) & 0xFFFF or 1
        wire = bytes(
            Frame.make(MessageType.REQUEST_STATUS, body, tid=tid, dest=Address(0, 1), src=CC_MAIN)
        )
        os.write(fd, wire)
        sent = time.perf_counter()
        if not select.select([fd], [], [], 2.0)[0]:
            raise RuntimeError("no Level 2 reply within 2 s")
        answered = time.perf_counter()
        time.sleep(0.002)  # the rest of the reply
        while select.select([fd], [], [], 0)[0]:
            os.read(fd, 4096)
        if i >= 20:
            out.append((answered - sent) * 1000)
        time.sleep(spacing_s)
    return out


class Stamps(logging.Handler):
    """Times of the bridge's own log lines, by their first words."""

    def __init__(self) -> None:
        super().__init__()
        self.times: dict[str, list[float]] = {}

    def emit(self, record: logging.LogRecord) -> None:
        key = " ".join(record.getMessage().split()[:2])
        self.times.setdefault(key, []).append(time.perf_counter())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", type=int, default=SAMPLES)
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--period", type=int, default=PERIOD_S)
    parser.add_argument("--send-delay", type=float, default=SEND_DELAY_S)
    args = parser.parse_args(argv)
    os.environ.setdefault("SHORESIDE_DATA_DIR", tempfile.mkdtemp(prefix="shoreside-bench-"))
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "fleet.settings")
    import django

    django.setup()
    from django.core.management import call_command

    from sms.bridge.process import Bridge, BridgeConfig
    from sms.level2.payload import (
        CommandCompleted,
        MemoryCommandSource,
        PayloadConfig,
        PayloadMachine,
    )
    from sms.level2.runner import PayloadRunner, PtyPort, SerialLink
    from sms.level2.simulator import CcSimulator, RealClock, SimConfig
    from sms.modem.simulator import ModemServer
    from sms.services import authorised_number_authorise
    from vessels.models import Vessel
    from vessels.services import vessel_create

    logging.disable(logging.NOTSET)
    call_command("migrate", verbosity=0)
    glider = Vessel.objects.filter(slug="bench-glider").first() or vessel_create(
        slug="bench-glider", name="Bench glider", kind="wave_glider"
    )
    authorised_number_authorise(number=NUMBER, vessels=[glider], role="control", name="Bench")
    # The backlog comes from many phones: one phone's identical texts within a second are one
    # delivery (the modem's time stamp has whole seconds), and one phone is rate limited.
    phones = [f"+614001{i:05d}" for i in range(BACKLOG)]
    for phone in phones:
        authorised_number_authorise(number=phone, vessels=[glider], role="query", name=phone)
    print(f"wg_bridge benchmark: C&C period {args.period} s, database {connection_name()}")

    # -- the bare runner: Level 2 latency, request queued → reply, ACK → notification ---------
    bare_port = PtyPort(timeout=1.0)
    memory = MemoryCommandSource()
    acked: list[float] = []

    def bare_note(note: object) -> None:
        if isinstance(note, CommandCompleted):
            acked.append(time.perf_counter())

    bare = PayloadRunner(
        bare_port.name,
        PayloadMachine(PayloadConfig(poll_period_s=args.period), source=memory),
        on_notification=bare_note,
    )
    threading.Thread(target=bare.run, daemon=True).start()
    assert bare.connected.wait(5)
    bare_latency = level2_latency(
        bare_port, args.samples, min(0.05, BACKLOG * args.send_delay * 0.8 / args.samples)
    )
    bare_handover, bare_ack = cc_rounds(
        bare_port,
        args,
        before_poll=lambda: memory.add("fhead 230"),
        acked=acked,
        sim_factory=(CcSimulator, SerialLink, SimConfig, RealClock),
    )
    bare.stop()

    # -- the bridge ---------------------------------------------------------------------------
    stamps = Stamps()
    for name in ("sms.bridge.sms_link",):
        logger = logging.getLogger(name)
        logger.addHandler(stamps)
        logger.setLevel(logging.INFO)
    cc_port = PtyPort(timeout=1.0)
    modem = TimedModem(capacity=BACKLOG + 10)
    server = ModemServer(modem, "pty").start()
    config = BridgeConfig(
        vessel=glider.slug,
        level2_port=cc_port.name,
        modem_port=server.url,
        poll_period_s=args.period,
        reply_window_s=10.0 * args.period,
    )
    bridge = Bridge(config, vessel=glider, modem_config={"settle_s": 0.02})
    thread = threading.Thread(target=bridge.run, daemon=True)
    thread.start()
    assert bridge.runner.connected.wait(5)
    # Busy modem: a backlog of query replies, each +CMGS answered late.
    modem.faults.send_delay_s = args.send_delay
    for i in range(BACKLOG):
        modem.inject(phones[i], "#FHEAD" if i % 2 else "#STATUS")
    deadline = time.monotonic() + 10
    while not modem.sent and time.monotonic() < deadline:
        time.sleep(0.01)
    # Spread over the backlog's sending time, so that every sample meets a busy modem.
    spacing = min(0.05, BACKLOG * args.send_delay * 0.8 / args.samples)
    busy_latency = level2_latency(cc_port, args.samples, spacing)
    busy_sent = len(modem.sent)
    while len(modem.sent) < BACKLOG and time.monotonic() < deadline + 30:
        time.sleep(0.05)
    modem.faults.send_delay_s = 0.0
    modem.cmgs_at.clear()

    def inject() -> None:
        stamps.times.clear()
        modem.arrived = time.perf_counter()
        # A new heading each round: the same text from the same phone in the same second (the
        # modem's time stamp has whole seconds) is a re-delivery, and its round would be lost.
        modem.inject(NUMBER, round_text(len(arrivals)))
        while "SMS in" not in stamps.times:
            time.sleep(0.001)

    arrivals: list[float] = []
    stored: list[float] = []

    def before_poll() -> None:
        inject()
        arrivals.append(modem.arrived)
        stored.append(stamps.times["SMS in"][0])

    bridge_handover, bridge_ack = cc_rounds(
        cc_port,
        args,
        before_poll=before_poll,
        acked=modem.cmgs_at,
        sim_factory=(CcSimulator, SerialLink, SimConfig, RealClock),
        arrivals=arrivals,
    )
    bridge.stop()
    thread.join(15)
    server.stop()

    print()
    show(
        f"Level 2 reply to a status request (modem busy: {busy_sent} replies out at "
        f"{args.send_delay:g} s each)",
        busy_latency,
        bare_latency,
    )
    sms_store = [(s - a) * 1000 for a, s in zip(arrivals, stored, strict=False)]
    own = [s + h for s, h in zip(sms_store, bridge_handover.reply_ms, strict=False)]
    show("request queued → queued reply (the handover)", bridge_handover.reply_ms,
         bare_handover.reply_ms)  # fmt: skip
    show("SMS arrives → command queued in the database", sms_store, [])
    show("bridge's own time, SMS → C&C (the two above)", own, [])
    show(
        f"SMS arrives → inner command at the C&C (poll period {args.period} s, then the "
        f"C&C's own {QUEUED_DELAY_S:g} s before its request, docs/level2.md)",
        bridge_handover.total_ms,
        [],
    )
    show("C&C ACK → reply SMS handed to the modem (AT+CMGS)", bridge_ack, bare_ack)
    return 0


def round_text(round_: int) -> str:
    """The SMS of one round: a heading command, different in every round of a run."""
    return f"#FHEAD {(230 + round_) % 360}"


def connection_name() -> str:
    from django.db import connection

    return f"{connection.vendor} {connection.settings_dict['NAME']}"


class Handover:
    def __init__(self) -> None:
        self.reply_ms: list[float] = []
        self.total_ms: list[float] = []


def cc_rounds(
    port: object,
    args: argparse.Namespace,
    *,
    before_poll: Callable[[], None],
    acked: list[float],
    sim_factory: tuple,
    arrivals: list[float] | None = None,
) -> tuple[Handover, list[float]]:
    """``--rounds`` times: queue a command at a random point of the poll period, let the C&C
    simulator (real time) take it; time the handover and the ACK's consequence."""
    cc_cls, link_cls, config_cls, clock_cls = sim_factory
    marks: dict[str, float] = {}
    ack_sent: list[float] = []
    handover = Handover()

    def trace(line: str) -> None:
        now = time.perf_counter()
        if line.startswith("C&C -> REQUEST_QUEUED"):
            marks["request"] = now
        elif "queued-reply command" in line:
            handover.reply_ms.append((now - marks["request"]) * 1000)
            marks["command"] = now
        elif line.startswith("C&C -> ACK_NAK_QUEUED"):
            ack_sent.append(now)

    sim = cc_cls(link_cls(port), config_cls(period_s=float(args.period)), clock_cls(), trace)
    stop = threading.Event()
    assert sim.enumerate()

    def poll() -> None:
        next_poll = time.monotonic()
        while not stop.is_set():
            next_poll += args.period
            stop.wait(max(0.0, next_poll - time.monotonic()))
            if not stop.is_set():
                sim.poll_once()

    threading.Thread(target=poll, daemon=True).start()
    acked.clear()
    ack_ms: list[float] = []
    for round_ in range(args.rounds):
        time.sleep(args.period * ((round_ * 0.37) % 1))  # spread over the period
        marks.pop("command", None)
        before_poll()
        deadline = time.monotonic() + 4 * args.period + 5
        while ("command" not in marks or len(acked) <= round_) and time.monotonic() < deadline:
            time.sleep(0.001)
        if arrivals is not None and "command" in marks:
            handover.total_ms.append((marks["command"] - arrivals[-1]) * 1000)
        if len(acked) > round_ and len(ack_sent) > round_:
            ack_ms.append((acked[round_] - ack_sent[round_]) * 1000)
    stop.set()
    return handover, ack_ms


class TimedModem(SimulatedModem):
    """The simulated modem, noting when each AT+CMGS is typed (the reply handed over)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self.cmgs_at: list[float] = []
        self.arrived = 0.0

    def receive(self, data: bytes) -> None:
        if b"AT+CMGS" in data.upper():
            self.cmgs_at.append(time.perf_counter())
        super().receive(data)


if __name__ == "__main__":
    sys.exit(main())
