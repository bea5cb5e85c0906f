"""Two checks for scripts/demo.sh, standard library only (it runs before the install).

``python3 scripts/netcheck.py free PORT=tcp:8000 BOAT_PORT=udp:14550 …`` exits 1, saying
which, when a port cannot be bound on 127.0.0.1 (something else has it).
``python3 scripts/netcheck.py answers URL --pid N [--timeout S]`` waits until the URL answers
200, and exits 1 if process N ends first or the time runs out.
"""

from __future__ import annotations

import argparse
import os
import socket
import sys
import time
import urllib.error
import urllib.request

KINDS = {"tcp": socket.SOCK_STREAM, "udp": socket.SOCK_DGRAM}


def busy(kind: str, port: int) -> str | None:
    """Why ``port`` cannot be ours on 127.0.0.1, or None if it is free."""
    with socket.socket(socket.AF_INET, KINDS[kind]) as sock:
        if kind == "tcp":
            # As gunicorn binds: a port left in TIME_WAIT by a stopped server is free to it.
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind(("127.0.0.1", port))
        except OSError as exc:
            return exc.strerror or str(exc)
    return None


def check_free(specs: list[str]) -> int:
    problems = []
    for spec in specs:
        name, _, where = spec.rpartition("=")
        kind, _, number = where.partition(":")
        if kind not in KINDS or not number.isdigit() or not 0 < int(number) < 65536:
            problems.append(f"{name or where}={number or where!r} is not a port number (1–65535)")
            continue
        why = busy(kind, int(number))
        if why:
            setting = name.partition("+")[0]  # BOAT_PORT+10 is moved by BOAT_PORT
            problems.append(
                f"{kind.upper()} port {number} ({name}) is in use ({why}): another program, or "
                f"a demo already running, has it. Stop it, or choose another: {setting}=… "
                "bash scripts/demo.sh"
            )
    for problem in problems:
        print(f"demo: {problem}", file=sys.stderr)
    return 1 if problems else 0


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def wait_answers(url: str, pid: int | None, timeout_s: float) -> int:
    deadline = time.monotonic() + timeout_s
    last = "no answer yet"
    while time.monotonic() < deadline:
        if pid is not None and not alive(pid):
            print(f"demo: the site stopped before it answered ({last})", file=sys.stderr)
            return 1
        try:
            with urllib.request.urlopen(url, timeout=5) as response:  # noqa: S310 - our own URL
                if response.status == 200:
                    return 0
                last = f"HTTP {response.status}"
        except urllib.error.HTTPError as exc:
            last = f"HTTP {exc.code}"
        except (OSError, ValueError) as exc:
            last = str(getattr(exc, "reason", exc))
        time.sleep(0.3)
    print(f"demo: {url} did not answer within {timeout_s:g} s ({last})", file=sys.stderr)
    return 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="what", required=True)
    free = sub.add_parser("free")
    free.add_argument("ports", nargs="+", help="NAME=tcp:PORT or NAME=udp:PORT")
    answers = sub.add_parser("answers")
    answers.add_argument("url")
    answers.add_argument("--pid", type=int, help="give up when this process ends")
    answers.add_argument("--timeout", type=float, default=120.0)
    args = parser.parse_args(argv)
    if args.what == "free":
        return check_free(args.ports)
    return wait_answers(args.url, args.pid, args.timeout)


if __name__ == "__main__":
    sys.exit(main())
