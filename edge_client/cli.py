"""Command line: ``python -m edge_client [run|check] --config PATH [overrides]``.

``python -m edge_client compact encode|decode FILE`` is the compact fix codec's tool
(edge_client/compact_cli.py).

``run`` (the default) runs the client until SIGTERM/SIGINT. ``check`` tests the autopilot link
and the server link once and says which one fails. Exit status: 0 ok, 1 failure, 2 bad config.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading

from edge_client import __version__
from edge_client.config import Config, ConfigError, load_config

log = logging.getLogger("edge_client")

COMMANDS = ("run", "check")


def build_parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--config", metavar="PATH", help="TOML config file (optional with flags)")
    common.add_argument("--server", metavar="URL", help="shore server base URL")
    common.add_argument(
        "--key",
        metavar="KEY",
        help="vessel API key; shows in `ps`: prefer --key-file or $SHORESIDE_EDGE_KEY",
    )
    common.add_argument(
        "--key-file", metavar="PATH", help="file holding the vessel API key (readable by us only)"
    )
    common.add_argument(
        "--mavlink",
        metavar="CONNECTION",
        help="serial device or udpin:/udpout:/tcp: connection string",
    )
    common.add_argument("--baud", metavar="N", help="serial baud rate (default 57600)")
    common.add_argument("--telemetry-period", metavar="S", help="seconds between fixes")
    common.add_argument("--poll-period", metavar="S", help="seconds between command polls")
    common.add_argument("--outbox", metavar="PATH", help="outbox sqlite file")
    common.add_argument("--transport", choices=("http", "modem"), help="how to reach the server")
    common.add_argument("--modem-port", metavar="PORT", help="F2414 modem serial port")
    common.add_argument("--log-level", choices=("DEBUG", "INFO", "WARNING", "ERROR"))
    parser = argparse.ArgumentParser(
        prog="python -m edge_client",
        description="Shoreside edge client: ArduPilot (MAVLink) <-> shore server.",
    )
    parser.add_argument("--version", action="version", version=f"edge_client {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("run", parents=[common], help="run the client (default)")
    check = sub.add_parser("check", parents=[common], help="test the autopilot and server links")
    check.add_argument(
        "--timeout",
        type=float,
        default=10.0,
        metavar="S",
        help="seconds to wait for the autopilot's HEARTBEAT (default 10)",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    args_list = list(sys.argv[1:] if argv is None else argv)
    if args_list[:1] == ["compact"]:  # a tool, not the client: no configuration
        from edge_client.compact_cli import main as compact_main

        return compact_main(args_list[1:])
    if not args_list or (
        args_list[0] not in COMMANDS and args_list[0] not in ("-h", "--help", "--version")
    ):
        args_list.insert(0, "run")  # as docs/edge-client.md: `python -m edge_client --config ...`
    args = build_parser().parse_args(args_list)
    overrides = {
        "server": args.server,
        "key": args.key,
        "key_file": args.key_file,
        "mavlink": args.mavlink,
        "baud": args.baud,
        "telemetry_period": args.telemetry_period,
        "poll_period": args.poll_period,
        "outbox": args.outbox,
        "transport": args.transport,
        "modem_port": args.modem_port,
        "log_level": args.log_level,
    }
    try:
        config = load_config(args.config, overrides)
    except ConfigError as exc:
        print(f"edge_client: bad configuration: {exc}", file=sys.stderr)
        return 2
    logging.basicConfig(
        level=config.log_level,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    if args.command == "check":
        return check(config, timeout=args.timeout)
    return run(config)


def run(config: Config, stop: threading.Event | None = None) -> int:
    """Run the client until the stop flag is set (SIGTERM and SIGINT set it)."""
    from edge_client.client import EdgeClient
    from edge_client.mavlink_link import MavlinkLink
    from edge_client.outbox import Outbox
    from edge_client.transports import make_transport

    stop = stop or threading.Event()
    if threading.current_thread() is threading.main_thread():
        # Handlers only set a flag; the main loop notices within 0.2 s and shuts down cleanly.
        for signum in (signal.SIGTERM, signal.SIGINT):
            signal.signal(signum, lambda *_: stop.set())
    try:
        outbox = Outbox(
            config.outbox.path,
            max_fixes=config.outbox.max_fixes,
            commit_every=config.outbox.commit_every,
        )
    except Exception as exc:
        log.error("cannot open the outbox %s: %s", config.outbox.path, exc)
        return 1
    client = EdgeClient(
        config,
        transport=make_transport(config),
        link=MavlinkLink(config.mavlink, config.readings),
        outbox=outbox,
        stop=stop,
    )
    try:
        return client.run()
    finally:
        outbox.close()


def check(config: Config, timeout: float = 10.0) -> int:
    """Test both links once; print one line each and say which one fails."""
    from edge_client.client import TELEMETRY_PATH
    from edge_client.mavlink_link import MavlinkLink
    from edge_client.transports import TransportError, make_transport

    ok = True
    link = MavlinkLink(config.mavlink, config.readings)
    link.start()
    try:
        if link.wait_heartbeat(timeout):
            state = link.state
            position = f"{state.lat:.6f}, {state.lon:.6f}" if state.lat is not None else "no fix"
            print(
                f"autopilot: OK  system {state.system} on {config.mavlink.connection}, "
                f"mode {state.mode}, {'armed' if state.armed else 'disarmed'}, {position}"
            )
        else:
            ok = False
            print(
                f"autopilot: FAILED  no HEARTBEAT within {timeout:g} s on "
                f"{config.mavlink.connection}"
            )
    finally:
        link.stop()
    transport = make_transport(config)
    try:
        # An empty batch proves the URL and the key without side effects: polling the
        # commands instead would mark the boat's queued commands as sent.
        transport.post_json(TELEMETRY_PATH, {"fixes": []})
        print(f"server: OK  {config.server.url} ({config.transport.kind}), vessel key accepted")
    except TransportError as exc:
        ok = False
        if exc.status in (401, 403):
            print(f"server: FAILED  {config.server.url} refused the vessel key ({exc})")
        else:
            print(f"server: FAILED  {config.server.url}: {exc}")
    finally:
        transport.close()
    return 0 if ok else 1
