"""Watch the bridge work: ``python -m sms.bridge.demo`` (issue 11 item 7).

Runs, in one process, the C&C simulator and the modem simulator on pseudo-terminals and the
bridge between them, for a demo glider in its own SQLite database (``--data-dir``, default
``./wg-demo-data``) with one authorised control number, ``+61400000001``. Type SMS as the phone
would send them, ``<number> <text>``::

    +61400000001 #FHEAD 230
    +61400000001 #LIGHT ON; #FHEAD 200
    +61400000001 #STATUS
    +61400000009 #FHEAD 90          (a stranger: logged, never answered)

and watch the trace: the SMS in, the flagged status reply, the C&C's request, the handover,
the ACK (``--ack nak``: a NAK, ``cycle``: every code in turn), the SMS out. ``!reset`` and
``!garbage`` upset the simulated modem. Ctrl-D or Ctrl-C stops it. ``--position-period 60``
texts the glider's position to the demo phone each minute (issue 20 §5).
"""

from __future__ import annotations

import argparse
import logging
import os
import select
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path

from sms.modem.simulator import SimulatedModem  # no Django: safe before django.setup()

DEMO_SLUG = "demo-glider"
DEMO_NUMBER = "+61400000001"
ACKS = {"ack": lambda _i, _p: 0, "nak": lambda _i, _p: 2, "cycle": lambda i, _p: i % 5}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sms.bridge.demo", description=__doc__)
    parser.add_argument("--data-dir", default="wg-demo-data", help="the demo's own database")
    parser.add_argument("--period", type=int, default=2, help="C&C poll period, s")
    parser.add_argument("--reply-window", type=float, help="s (default: period + margin)")
    parser.add_argument("--ack", choices=sorted(ACKS), default="ack")
    parser.add_argument("--duration", type=float, help="stop after this many seconds")
    parser.add_argument("--all-polls", action="store_true", help="trace every status poll")
    parser.add_argument(
        "--position-period",
        type=float,
        default=0.0,
        help="text the position to the demo phone every this many s (0: never; at least 60)",
    )
    args = parser.parse_args(argv)

    # The demo's own database, chosen before Django reads its settings.
    os.environ.pop("DATABASE_URL", None)
    os.environ["SHORESIDE_DATA_DIR"] = str(Path(args.data_dir).resolve())
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "fleet.settings")
    import django

    django.setup()
    return _run(args)


def _run(args: argparse.Namespace) -> int:
    from django.core.management import call_command

    from sms.bridge.process import Bridge, BridgeConfig
    from sms.bridge.records import RecordTable
    from sms.bridge.sensor_standin import RecordServer, demo_values
    from sms.level2.runner import PtyPort, SerialLink
    from sms.level2.simulator import CcSimulator, RealClock, SimConfig
    from sms.modem.simulator import ModemServer
    from sms.selectors import bridge_vessel
    from sms.services import authorised_number_authorise
    from vessels.models import Vessel
    from vessels.services import vessel_create

    logging.basicConfig(
        level=logging.INFO,
        format="%(asctime)s.%(msecs)03d %(threadName)-9s %(message)s",
        datefmt="%H:%M:%S",
        stream=sys.stdout,
    )
    for noisy in ("sms.modem.driver", "django"):
        logging.getLogger(noisy).setLevel(logging.WARNING)
    say = logging.getLogger("demo").info
    call_command("migrate", verbosity=0)
    try:
        glider = bridge_vessel(DEMO_SLUG)
    except Vessel.DoesNotExist:
        glider = vessel_create(slug=DEMO_SLUG, name="Demo glider", kind="wave_glider")
    authorised_number_authorise(
        number=DEMO_NUMBER,
        vessels=[glider],
        role="control",
        name="Demo phone",
        receives_positions=args.position_period > 0,
    )

    # The payload board's stasis data server, stood in for on a free UDP port.
    stasis = RecordTable.load().records["stasis"]
    board = RecordServer(stasis, demo_values(stasis), port=0).start()
    cc_port = PtyPort(timeout=0.01)
    modem = SimulatedModem()
    server = ModemServer(modem, "pty").start()
    config = BridgeConfig(
        vessel=glider.slug,
        level2_port=cc_port.name,
        modem_port=server.url,
        poll_period_s=args.period,
        reply_window_s=args.reply_window,
        result_timeout_s=max(10.0, 3.0 * args.period),
        quarantine_s=max(5.0, args.period),
        sensor_host="127.0.0.1",
        sensor_ports={stasis.name: board.port},
        position_sms_period_s=args.position_period,
    )
    bridge = Bridge(config, vessel=glider)
    stop = bridge.stop_event

    def cc_trace(line: str) -> None:
        if args.all_polls or "status-" not in line or " QUEUED" in line:
            logging.getLogger("C&C").info(line)

    sim = CcSimulator(
        SerialLink(cc_port),
        SimConfig(period_s=float(args.period), ack_policy=ACKS[args.ack]),
        RealClock(),
        trace=cc_trace,
    )

    def run_cc() -> None:
        # The simulator polls in protocol time; ending its run ends the demo.
        sim.run(args.duration if args.duration is not None else 10**9)
        stop.set()

    cc = threading.Thread(target=run_cc, name="c&c-sim", daemon=True)
    signal.signal(signal.SIGINT, lambda _s, _f: stop.set())
    signal.signal(signal.SIGTERM, lambda _s, _f: stop.set())
    bridge_thread = threading.Thread(target=bridge.run, name="main", daemon=True)
    bridge_thread.start()
    cc.start()
    say(f"demo glider {glider.slug!r} in {os.environ['SHORESIDE_DATA_DIR']}")
    say(f"C&C polls every {args.period} s; reply window {config.reply_window:g} s")
    say(f"type an SMS as '<number> <text>', e.g. '{DEMO_NUMBER} #FHEAD 230'")
    reported = 0
    try:
        while not stop.is_set():
            if select.select([sys.stdin], [], [], 0.1)[0]:
                line = sys.stdin.readline()
                if not line:
                    break
                _typed(line.strip(), modem, say)
            for sms in modem.sent[reported:]:
                say(f"SMS delivered to {sms.number}: {sms.text}")
                reported += 1
    finally:
        stop.set()
        bridge_thread.join(15)
        server.stop()
        board.stop()
        cc_port.close()
    say(f"C&C: {sim.stats.summary()}")
    return 0


def _typed(line: str, modem: SimulatedModem, say: Callable[[str], None]) -> None:
    if not line:
        return
    if line == "!reset":
        modem.reset()
        say("modem: reset")
        return
    if line == "!garbage":
        modem.garbage()
        say("modem: a line of garbage")
        return
    number, _, text = line.partition(" ")
    if not text:
        say("type '<number> <text>'")
        return
    index = modem.inject(number, text)
    say(f"SMS from {number} arrives at the modem (slot {index}): {text}")


if __name__ == "__main__":
    sys.exit(main())
