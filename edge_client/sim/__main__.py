"""Run the simulated Rover: ``python -m edge_client.sim --listen udpin:127.0.0.1:14550``.

Then, in another terminal, point the edge client at it::

    python -m edge_client run --server http://127.0.0.1:8000 --key KEY \\
        --mavlink udpout:127.0.0.1:14550 --outbox /tmp/outbox.sqlite3
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
import time

from edge_client.sim.rover import MODES, RoverSim


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m edge_client.sim", description=__doc__.splitlines()[0]
    )
    p.add_argument(
        "--listen",
        action="append",
        metavar="CONNECTION",
        help="pymavlink connection string, repeatable (default udpin:127.0.0.1:14550)",
    )
    p.add_argument("--lat", type=float, default=-31.98, help="start latitude")
    p.add_argument("--lon", type=float, default=115.82, help="start longitude")
    p.add_argument(
        "--speed",
        type=float,
        default=2.0,
        help="cruise speed in m/s (Rover's WP_SPEED; a mission's DO_CHANGE_SPEED overrides it "
        "until the next mode change)",
    )
    p.add_argument(
        "--wp-radius",
        type=float,
        default=2.0,
        help="Rover's WP_RADIUS in metres: a mission waypoint counts as reached this close",
    )
    p.add_argument("--rate", type=float, default=4.0, help="GLOBAL_POSITION_INT rate in Hz")
    p.add_argument(
        "--prearm-delay",
        type=float,
        default=20.0,
        help="seconds after start before pre-arm checks pass",
    )
    p.add_argument(
        "--position-delay",
        type=float,
        default=0.0,
        help="seconds after start before the EKF has a position (GPS fix at half of it); "
        "until then, armed, modes that need a position are refused (a real Rover: 30-60)",
    )
    p.add_argument(
        "--ekf-failsafe",
        type=float,
        default=1.0,
        metavar="S",
        help="seconds after the position is good before the EKF failsafe (raised when armed "
        "without one) clears; until then, armed, such modes are still refused (Rover: about 1)",
    )
    p.add_argument(
        "--request-int",
        action="store_true",
        help="request upload items with MISSION_REQUEST_INT (default: MISSION_REQUEST)",
    )
    p.add_argument("--drop", type=float, default=0.0, help="probability of dropping a message")
    p.add_argument("--dup", type=float, default=0.0, help="probability of duplicating a message")
    p.add_argument(
        "--refuse-mode",
        action="append",
        default=[],
        choices=sorted(MODES),
        help="refuse changes to this mode (COMMAND_ACK DENIED), repeatable",
    )
    p.add_argument(
        "--reject-mission",
        type=int,
        metavar="CODE",
        help="answer every upload with this MAV_MISSION_RESULT (e.g. 4 = NO_SPACE)",
    )
    p.add_argument("--seed", type=int, help="random seed for fault injection")
    p.add_argument(
        "--time-scale",
        type=float,
        default=1.0,
        metavar="X",
        help="run the vehicle's clock X times faster than real time (motion, stream rates, "
        "delays, mission timeouts; for tests)",
    )
    p.add_argument(
        "--status-every",
        type=float,
        default=0.0,
        metavar="S",
        help="print position/mode every S seconds (0 = never)",
    )
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO)
    sim = RoverSim(
        args.listen or ["udpin:127.0.0.1:14550"],
        lat=args.lat, lon=args.lon, speed_mps=args.speed, wp_radius_m=args.wp_radius,
        rate_hz=args.rate,
        prearm_delay_s=args.prearm_delay, position_delay_s=args.position_delay,
        ekf_failsafe_s=args.ekf_failsafe,
        request_int=args.request_int, drop=args.drop,
        dup=args.dup, refuse_modes=tuple(args.refuse_mode), reject_mission=args.reject_mission,
        seed=args.seed, time_scale=args.time_scale,
    )  # fmt: skip
    stop = threading.Event()
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: stop.set())
    print(f"sim: listening on {', '.join(args.listen or ['udpin:127.0.0.1:14550'])}", flush=True)
    next_status = time.monotonic()
    while not stop.is_set():
        sim.step()
        if args.status_every and time.monotonic() >= next_status:
            next_status += args.status_every
            print(
                f"sim: {sim.lat:.6f} {sim.lon:.6f} {sim.mode_name} "
                f"{'armed' if sim.armed else 'disarmed'} item {sim.current} "
                f"{sim.speed:g} m/s",
                flush=True,
            )
        stop.wait(0.005)
    sim.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
