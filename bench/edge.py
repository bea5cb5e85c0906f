"""Edge client footprint: memory, CPU and bytes on the wire, against the original SPAB client.

    python -m bench.edge [--duration 60] [--before REF]

Runs, side by side for ``--duration`` seconds (after a short warm-up):

- the simulated Rover (``edge_client.sim``) streaming GLOBAL_POSITION_INT at 4 Hz, one per client;
- the edge client (real process, HTTP transport) with telemetry every 2 s, its uplink every 2 s
  (the original cadence) and every 10 s (the default), each against its own tiny stdlib HTTP
  server that speaks the boat API (ETag/304 and the telemetry answer's command exchange
  included) and counts every byte in and out; at each cadence twice: this client, and either
  this client with ``[commands] exchange = false`` or, with ``--before REF`` (e.g. ``main``),
  the edge client of that git ref, unpacked with ``git archive``; and a third time this client
  with ``[telemetry] encoding = "compact"`` (its autopilot readings as the channel table);
- the original SPAB client as a baseline (docs/benchmarks.md): every 2 s one JSON fix per POST to
  ``data.cgi`` and a full GET of ``requestCommands.cgi``, one TCP connection per request as
  through the F2414 modem, with minimal hand-written headers (generous to the baseline);
- an idle Python with the same imports, as the memory baseline.

Bytes are HTTP bytes (request and response lines, headers, bodies); TCP/IP and TLS overhead is
not counted, but the number of TCP connections is shown (the original client opened one per
request; the HTTP transport keeps one alive).

Then the outbox's writes to its storage (an SD card on the Pi) for an hour of 1 Hz fixes, run
without waiting (``--outbox-only`` runs just this part): the group commits against the old
behaviour, one ``synchronous=FULL`` transaction per fix and per removal, measured in the same
run as the baseline. Each variant runs in its own process: commits are counted on the sqlite
connection, bytes and write calls from /proc/<pid>/io (``wchar``/``syscw``: what the process
handed to write(), the db and WAL files being all it writes), fsync/fdatasync calls with
``strace -c`` when strace is installed.
"""

from __future__ import annotations

import argparse
import http.client
import io
import json
import os
import shutil
import socket
import subprocess
import sys
import tarfile
import tempfile
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from edge_client.contract import compact
from edge_client.contract.fix import AUTOPILOT_READINGS
from vessels.keys import generate_key

ROOT = Path(__file__).resolve().parents[1]
# The compact variant's channel table: the readings the edge client takes from the autopilot.
AUTOPILOT_CHANNELS = [compact.Channel(name, 1) for name in AUTOPILOT_READINGS]
# A key of the real length (ssk_ and 43 characters): its header is on every request.
BOAT_KEY = generate_key()
TELEMETRY_PERIOD_S = 2.0
EXCHANGE_HEADER = "X-Commands-ETag"
SIM_RATE_HZ = 4.0
WARMUP_S = 6.0
TARGET_RSS_MB = 60.0
TARGET_CPU_PCT = 3.0
CLK_TCK = os.sysconf("SC_CLK_TCK")


class Counting:
    """A file wrapper that counts bytes read or written."""

    def __init__(self, inner, counter: dict, key: str) -> None:
        self.inner, self.counter, self.key = inner, counter, key

    def read(self, *a):
        data = self.inner.read(*a)
        self.counter[self.key] += len(data)
        return data

    def readline(self, *a):
        data = self.inner.readline(*a)
        self.counter[self.key] += len(data)
        return data

    def write(self, data):
        self.counter[self.key] += len(data)
        return self.inner.write(data)

    def __getattr__(self, name):
        return getattr(self.inner, name)


class BoatApi(BaseHTTPRequestHandler):
    """The boat API (v1) and the legacy SPAB endpoints, just enough to answer like the server."""

    protocol_version = "HTTP/1.1"
    ETAG = '"c1.1"'

    def setup(self) -> None:
        super().setup()
        stats = self.server.stats
        stats["connections"] += 1
        self.rfile = Counting(self.rfile, stats, "up")
        self.wfile = Counting(self.wfile, stats, "down")

    def _body(self) -> object:
        length = int(self.headers.get("Content-Length") or 0)
        raw = self.rfile.read(length) if length else b""
        if self.headers.get("Content-Type") == compact.CONTENT_TYPE:
            return {"fixes": compact.decode(raw, AUTOPILOT_CHANNELS)}
        return json.loads(raw) if raw else None

    def _send(self, status: int, payload: object | None, headers: dict | None = None) -> None:
        data = b"" if payload is None else json.dumps(payload).encode()
        self.send_response(status)
        for name, value in (headers or {}).items():
            self.send_header(name, value)
        if payload is not None:
            self.send_header("Content-Type", "application/json")
        if status != 204:  # a 204 has no body, nor a length (RFC 9110 §8.6)
            self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def do_POST(self) -> None:
        self.server.stats["requests"] += 1
        body = self._body()
        if self.path == "/api/v1/boat/telemetry/":
            fixes = body["fixes"]
            self.server.stats["fixes"] += len(fixes)
            answer = {"accepted": len(fixes), "duplicates": 0, "rejected": []}
            held = self.headers.get(EXCHANGE_HEADER)  # one exchange per period (docs/api.md)
            if held == self.ETAG and self.headers.get("Prefer") == "return=minimal":
                self._send(204, None)  # all stored, the list held is current: nothing to say
                return
            if held is not None:
                answer["commands"] = []
                answer["commands_etag"] = self.ETAG
            self._send(200, answer)
        elif self.path == "/spab/data.cgi":
            self.server.stats["fixes"] += 1 if isinstance(body, dict) else len(body)
            self._send(200, [{"type": "telemAck"}, {"success": "true", "message": "stored"}])
        else:
            self._send(404, {"error": "not_found", "detail": self.path})

    def do_GET(self) -> None:
        self.server.stats["requests"] += 1
        if self.path == "/api/v1/boat/commands/":
            if self.headers.get("If-None-Match") == self.ETAG:
                self._send(304, None, {"ETag": self.ETAG})
            else:
                self._send(200, {"commands": []}, {"ETag": self.ETAG})
        elif self.path.startswith("/spab/requestCommands.cgi"):
            self._send(200, [{"type": "command"}])
        else:
            self._send(404, {"error": "not_found", "detail": self.path})

    def log_message(self, *args) -> None:
        pass


def serve() -> ThreadingHTTPServer:
    server = ThreadingHTTPServer(("127.0.0.1", 0), BoatApi)
    server.stats = {"up": 0, "down": 0, "requests": 0, "connections": 0, "fixes": 0}
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def spawn(args: list[str], root: Path = ROOT) -> subprocess.Popen:
    """``python <args>`` importing the edge client found in ``root`` (cwd and path)."""
    env = {**os.environ, "PYTHONPATH": str(root)}
    env.pop("NOTIFY_SOCKET", None)
    return subprocess.Popen([sys.executable, *args], cwd=root, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip


def edge_client_of(ref: str, dest: Path) -> Path:
    """The edge_client package as it is at git ``ref``, unpacked under ``dest`` (its root)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", ref, "edge_client"],
                             check=True, capture_output=True).stdout  # fmt: skip
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(dest, filter="data")
    return dest


def cpu_ticks(pid: int) -> int:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])  # utime + stime (proc(5) fields 14 and 15)


def rss_mb(pid: int) -> tuple[float, float]:
    """(current VmRSS, peak VmHWM) in MB."""
    values = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(("VmRSS:", "VmHWM:")):
            name, kb = line.split(":")
            values[name] = int(kb.split()[0]) / 1024
    return values["VmRSS"], values["VmHWM"]


class EdgeRun:
    """One edge client with its simulator and its counting server.

    ``root``: where its edge_client package is (another git ref's: ``--before``);
    ``exchange``: this checkout's ``[commands] exchange`` (None: leave the key out, as an
    older client knows no such key)."""

    def __init__(
        self, label: str, poll_s: float, workdir: Path, *, root: Path = ROOT,
        exchange: bool | None = None, encoding: str | None = None,
    ) -> None:  # fmt: skip
        self.label = label
        self.server = serve()
        port = free_udp_port()
        self.sim = spawn(["-m", "edge_client.sim", "--listen", f"udpin:127.0.0.1:{port}",
                          "--rate", str(SIM_RATE_HZ), "--prearm-delay", "0"])  # fmt: skip
        name = f"{label.split(':')[0].replace(' ', '-')}-{poll_s}"
        config, text = [], ""
        if exchange is not None:
            text += f"[commands]\nexchange = {str(exchange).lower()}\n"
        if encoding is not None:
            table = ", ".join(f'{{name = "{c.name}", step = 1}}' for c in AUTOPILOT_CHANNELS)
            text += f'[telemetry]\nencoding = "{encoding}"\nchannels = [{table}]\n'
        if text:
            path = workdir / f"{name}-{encoding or 'json'}.toml"
            path.write_text(text)
            config = ["--config", str(path)]
        self.client = spawn([
            "-m", "edge_client", "run", *config, "--server",
            f"http://127.0.0.1:{self.server.server_address[1]}", "--key", BOAT_KEY,
            "--mavlink", f"udpout:127.0.0.1:{port}", "--outbox", str(workdir / f"{name}.db"),
            "--telemetry-period", str(TELEMETRY_PERIOD_S), "--poll-period", str(poll_s),
            "--log-level", "WARNING",
        ], root)  # fmt: skip

    def begin(self) -> None:
        self.t0, self.ticks0 = time.monotonic(), cpu_ticks(self.client.pid)
        self.stats0 = dict(self.server.stats)

    def end(self) -> dict:
        wall = time.monotonic() - self.t0
        cpu = (cpu_ticks(self.client.pid) - self.ticks0) / CLK_TCK / wall * 100
        rss, peak = rss_mb(self.client.pid)
        delta = {k: self.server.stats[k] - self.stats0[k] for k in self.stats0}
        return {"label": self.label, "wall": wall, "cpu": cpu, "rss": rss, "peak": peak, **delta}

    def close(self) -> None:
        for proc in (self.client, self.sim):
            proc.terminate()
            proc.wait(10)
        self.server.shutdown()


class SpabClient:
    """The SPAB client's loop: one fix per POST, a full GET every period, a connection each."""

    def __init__(self) -> None:
        self.server = serve()
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _request(self, method: str, path: str, body: bytes = b"") -> None:
        conn = http.client.HTTPConnection("127.0.0.1", self.server.server_address[1], timeout=5)
        headers = {"Content-Type": "application/json"} if body else {}
        conn.request(method, path, body=body or None, headers=headers)
        conn.getresponse().read()
        conn.close()

    def _run(self) -> None:
        n = 0
        while not self.stop.wait(TELEMETRY_PERIOD_S):
            n += 1
            fix = {"timestamp": int(time.time()), "latitude": -31.9505 + n * 1e-5,
                   "longitude": 115.8605, "temperature": 301.3, "salinity": 35.5}  # fmt: skip
            self._request("POST", "/spab/data.cgi", json.dumps(fix).encode())
            self._request("GET", "/spab/requestCommands.cgi")

    def begin(self) -> None:
        self.t0, self.stats0 = time.monotonic(), dict(self.server.stats)

    def end(self) -> dict:
        wall = time.monotonic() - self.t0
        delta = {k: self.server.stats[k] - self.stats0[k] for k in self.stats0}
        return {"label": "SPAB client: 1 fix/POST + full GET every 2 s", "wall": wall, **delta}

    def close(self) -> None:
        self.stop.set()
        self.thread.join(5)
        self.server.shutdown()


def idle_baseline_mb() -> float:
    code = ("import edge_client.client, edge_client.transports.http, edge_client.cli, time; "
            "print('ok', flush=True); time.sleep(30)")  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-c", code], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE)  # fmt: skip
    proc.stdout.readline()
    time.sleep(0.5)
    rss = rss_mb(proc.pid)[0]
    proc.kill()
    proc.wait()
    return rss


def per_hour(value: float, wall: float) -> float:
    return value * 3600 / wall


# -- the outbox's writes ----------------------------------------------------------------------

HOUR_OF_FIXES = 3600  # one hour at 1 Hz
OUTBOX_VARIANTS = {
    "per-fix": "before: FULL commit per fix and removal (baseline)",
    "grouped": "group commits (commit_every 10), rest NORMAL",
}
# (label, fixes between uplink rounds, does the server take them)
OUTBOX_SCENARIOS = [
    ("uplink every 10 s, server answering", 10, True),
    ("server unreachable: a failed round every 60 s", 60, False),
]


def proc_io() -> dict[str, int]:
    lines = Path("/proc/self/io").read_text().splitlines()
    return {k: int(v) for k, v in (line.split(": ") for line in lines)}


def outbox_workload(variant: str, path: str, every: int, accepted: bool) -> dict:
    """An hour of 1 Hz fixes through an Outbox, as the client drives it, without waiting."""
    from edge_client.outbox import Outbox

    if variant == "per-fix":
        box = Outbox(path, commit_every=1, synchronous="FULL")
    else:
        box = Outbox(path, commit_every=10)  # the [outbox] commit_every default
    commits = 0

    def count(sql: str) -> None:
        nonlocal commits
        commits += sql == "COMMIT"

    box._db.set_trace_callback(count)  # a bench may look inside
    io0, t0 = proc_io(), time.perf_counter()
    for n in range(HOUR_OF_FIXES):
        box.add_fix({"time": 1_800_000_000 + n, "lat": -31.98 + n * 1e-6, "lon": 115.82,
                     "heading_deg": 87.5, "speed_mps": 1.42, "battery_v": 12.61,
                     "readings": {"armed": 1, "mission_item": 3, "mode_number": 10,
                                  "water_temp_c": 18.5}})  # fmt: skip
        if (n + 1) % every == 0:  # an uplink round
            items = box.peek("fix", 100)
            if accepted:
                box.remove([i.id for i in items])
    box.close()
    wall, io1 = time.perf_counter() - t0, proc_io()
    return {"commits": commits, "wchar": io1["wchar"] - io0["wchar"],
            "syscw": io1["syscw"] - io0["syscw"], "wall": wall}  # fmt: skip


def run_outbox_workload(variant: str, every: int, accepted: bool, tmp: Path) -> dict:
    """Run one workload in a fresh process (twice under strace, to count the fsyncs)."""
    args = ["-m", "bench.edge", "--outbox-workload", variant, str(every), str(int(accepted))]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    db = tmp / f"{variant}-{every}.sqlite3"
    out = subprocess.run([sys.executable, *args, str(db)], cwd=ROOT, env=env, check=True,
                         capture_output=True, text=True).stdout  # fmt: skip
    result = json.loads(out)
    result["fsyncs"] = None
    if shutil.which("strace"):
        summary = tmp / "strace.txt"
        traced = tmp / f"traced-{variant}-{every}.sqlite3"
        subprocess.run(["strace", "-f", "-qq", "-c", "-e", "trace=fsync,fdatasync", "-o",
                        str(summary), sys.executable, *args, str(traced)], cwd=ROOT, env=env,
                       check=True, capture_output=True)  # fmt: skip
        rows = [line.split() for line in summary.read_text().splitlines()]
        result["fsyncs"] = sum(int(r[3]) for r in rows if r and r[-1] in ("fsync", "fdatasync"))
    return result


def outbox_report() -> None:
    print(f"Outbox writes for an hour of 1 Hz fixes ({HOUR_OF_FIXES} fixes, run without waiting)")
    with tempfile.TemporaryDirectory() as tmp:
        for label, every, accepted in OUTBOX_SCENARIOS:
            print()
            print(label)
            print(f"{'outbox':52} {'commits/h':>9} {'fsyncs/h':>9} {'write MB/h':>10} "
                  f"{'writes/h':>9} {'s/h':>6} {'fsyncs vs base':>14}")  # fmt: skip
            base = None
            for variant, name in OUTBOX_VARIANTS.items():
                r = run_outbox_workload(variant, every, accepted, Path(tmp))
                base = base or r
                fsyncs = "n/a" if r["fsyncs"] is None else f"{r['fsyncs']:9d}"
                vs = "" if not base["fsyncs"] else f"{r['fsyncs'] / base['fsyncs']:14.1%}"
                print(f"{name:52} {r['commits']:9d} {fsyncs:>9} {r['wchar'] / 1e6:10.2f} "
                      f"{r['syscw']:9d} {r['wall']:6.2f} {vs:>14}")  # fmt: skip
    if not shutil.which("strace"):
        print("(fsyncs not counted: strace is not installed)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.edge", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--duration", type=float, default=60.0, help="seconds measured (60)")
    parser.add_argument(
        "--outbox-only", action="store_true", help="only the outbox's writes (a few seconds)"
    )
    parser.add_argument(
        "--before",
        metavar="REF",
        help="also run the edge client of this git ref (e.g. main) beside this one, in place "
        "of this client with its exchange off",
    )
    parser.add_argument("--outbox-workload", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.outbox_workload:
        variant, every, accepted, path = args.outbox_workload
        print(json.dumps(outbox_workload(variant, path, int(every), accepted == "1")))
        return 0
    if args.outbox_only:
        outbox_report()
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        runs = []
        for poll_s, cadence in ((2.0, "uplink 2 s (as SPAB)"), (10.0, "uplink 10 s (default)")):
            if args.before:
                root = edge_client_of(args.before, Path(tmp) / "before")
                runs.append(EdgeRun(f"{args.before}: {cadence}", poll_s, Path(tmp), root=root))
            else:
                runs.append(EdgeRun(f"exchange off: {cadence}", poll_s, Path(tmp), exchange=False))
            runs.append(EdgeRun(f"this client: {cadence}", poll_s, Path(tmp), exchange=True))
        compact_runs = [
            EdgeRun(f"this client, compact fixes: {cadence}", poll_s, Path(tmp), exchange=True,
                    encoding="compact")
            for poll_s, cadence in ((2.0, "uplink 2 s (as SPAB)"), (10.0, "uplink 10 s (default)"))
        ]  # fmt: skip
        runs += compact_runs
        # The shortest uplink at which compact fixes cost under 30 % of the SPAB client's
        # bytes (fixes still sampled every 2 s): shown, not paired.
        runs.append(EdgeRun("this client, compact fixes: uplink 4 s", 4.0, Path(tmp),
                            exchange=True, encoding="compact"))  # fmt: skip
        spab = SpabClient()
        try:
            time.sleep(WARMUP_S)
            for r in [*runs, spab]:
                r.begin()
            time.sleep(args.duration)
            results = [r.end() for r in runs]
            baseline = spab.end()
        finally:
            for r in [*runs, spab]:
                r.close()
    idle = idle_baseline_mb()

    print(
        f"Edge client footprint: simulator at {SIM_RATE_HZ:g} Hz, telemetry every "
        f"{TELEMETRY_PERIOD_S:g} s, {args.duration:g} s measured after {WARMUP_S:g} s warm-up"
    )
    print()
    print(f"{'process':48} {'RSS MB':>8} {'peak MB':>8} {'CPU % core':>11}")
    print(f"{'idle python, same imports (baseline)':48} {idle:8.1f} {'':>8} {'':>11}")
    for r in results:
        print(f"{r['label']:48} {r['rss']:8.1f} {r['peak']:8.1f} {r['cpu']:11.2f}")
    print(f"{'target':48} {TARGET_RSS_MB:8.0f} {'':>8} {TARGET_CPU_PCT:11.1f}")
    print()
    print("Bytes on the wire per hour (HTTP: request/status lines, headers, bodies)")
    print(
        f"{'client (telemetry every 2 s)':48} {'up B/h':>9} {'down B/h':>9} {'total B/h':>10} "
        f"{'req/h':>6} {'TCP conn/h':>10} {'fixes/h':>8} {'vs SPAB':>9}"
    )
    base_total = per_hour(baseline["up"] + baseline["down"], baseline["wall"])
    for r in [baseline, *results]:
        total = per_hour(r["up"] + r["down"], r["wall"])
        print(
            f"{r['label']:48} {per_hour(r['up'], r['wall']):9.0f} "
            f"{per_hour(r['down'], r['wall']):9.0f} {total:10.0f} "
            f"{per_hour(r['requests'], r['wall']):6.0f} "
            f"{per_hour(r['connections'], r['wall']):10.0f} "
            f"{per_hour(r['fixes'], r['wall']):8.0f} {total / base_total:8.0%}"
        )
    print()
    paired, compacted = results[:-3], results[-3:-1]
    for before, after in [*zip(paired[::2], paired[1::2], strict=True),
                          *zip(paired[1::2], compacted, strict=True)]:  # fmt: skip
        ratio = (after["up"] + after["down"]) / after["wall"]
        ratio /= (before["up"] + before["down"]) / before["wall"]
        print(f"{after['label']}: {ratio:.0%} of the bytes of {before['label']}")
    ok = all(r["rss"] <= TARGET_RSS_MB and r["cpu"] <= TARGET_CPU_PCT for r in results)
    print()
    outbox_report()
    print()
    print("targets met" if ok else "TARGETS MISSED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
