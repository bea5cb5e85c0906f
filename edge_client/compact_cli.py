"""``python -m edge_client compact encode|decode``: the compact fix encoding for people and tools.

    python -m edge_client compact encode fixes.json > batch.bin
    python -m edge_client compact decode batch.bin > fixes.json
    ... --channels channels.json     # the vessel's channel table, for readings

``encode`` reads fixes in the API's JSON shape (a list, or ``{"fixes": [...]}``) and writes the
payload's bytes; it says on standard error how many bytes and fixes that was. ``decode`` writes
the fixes as JSON. ``-`` (or no file) is standard input. Exit status 0, or 1 with the reason.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, BinaryIO

from edge_client.contract.compact import Channel, CompactError, channels_from, decode, encode


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m edge_client compact",
        description="Encode fixes (JSON) to the compact payload, or decode one back to JSON.",
    )
    parser.add_argument("action", choices=("encode", "decode"))
    parser.add_argument("file", nargs="?", default="-", help="input file (default: stdin)")
    parser.add_argument(
        "--channels",
        metavar="PATH",
        help='the channel table, JSON [{"name": ..., "step": ...}, ...] (for readings)',
    )
    parser.add_argument(
        "--drop-unknown",
        action="store_true",
        help="leave out readings not in the channel table instead of refusing",
    )
    return parser


def main(argv: list[str]) -> int:
    args = build_parser().parse_args(argv)
    where = "stdin" if args.file == "-" else args.file
    try:
        channels = _table(args.channels)
        data = _read(args.file)
        if args.action == "encode":
            fixes = _fixes(data)
            payload = encode(fixes, channels, drop_unknown=args.drop_unknown)
            _stdout().write(payload)
            size = f"{len(payload)} bytes, {len(fixes)} fixes"
            print(f"{size} ({len(payload) / len(fixes):.1f} a fix)", file=sys.stderr)
        else:
            json.dump(decode(data, channels), sys.stdout, indent=1)
            sys.stdout.write("\n")
    except (CompactError, OSError, ValueError) as exc:
        print(f"compact {args.action}: {where}: {exc}", file=sys.stderr)
        return 1
    return 0


def _read(path: str) -> bytes:
    if path == "-":
        return sys.stdin.buffer.read()
    return Path(path).read_bytes()


def _stdout() -> BinaryIO:
    return sys.stdout.buffer


def _fixes(data: bytes) -> list[Any]:
    try:
        parsed = json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CompactError(f"not JSON: {exc}") from None
    if isinstance(parsed, dict) and "fixes" in parsed:
        parsed = parsed["fixes"]
    if not isinstance(parsed, list):
        raise CompactError('expected a JSON list of fixes, or {"fixes": [...]}')
    return parsed


def _table(path: str | None) -> list[Channel]:
    if path is None:
        return []
    try:
        table = json.loads(Path(path).read_text())
    except json.JSONDecodeError as exc:
        raise CompactError(f"the channel table {path} is not JSON: {exc}") from None
    if not isinstance(table, list):
        raise CompactError(f"the channel table {path} is not a JSON list")
    return channels_from(table)
