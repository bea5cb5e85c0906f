#!/usr/bin/env bash
# One command for the demo: install, migrate, seed a demo fleet, serve the site on
# http://127.0.0.1:$PORT/ (SQLite; no other service needed) and bring the fleet to life:
# - two Rover boats, each the real edge client driving the Rover MAVLink simulator
#   (manage.py simulate_boat), at its own start position and on its own UDP port;
# - a Wave Glider off Fremantle: the real glider bridge (manage.py run_wg_bridge) between a
#   simulated C&C box, GSM modem and payload board (manage.py simulate_glider), with its own
#   database in $SHORESIDE_DATA_DIR/glider and its shore link to this site under its key;
# - the alerts loop (manage.py run_alerts) watching them with the seeded rules.
# Text the glider from another terminal: .venv/bin/python manage.py demo_sms "+61400000001" "#FHEAD 230"
# Ctrl-C (or SIGTERM to this script) stops everything it started.
#
# Settings (environment variables):
#   PORT=8000           TCP port of the site, on 127.0.0.1
#   BOAT_PORT=14550     UDP port of the first boat's simulator; the second boat uses BOAT_PORT+10
#   SHORESIDE_DATA_DIR  database, keys and logs (default: shoreside-data beside the repository)
# The glider takes no fixed port: pseudo-terminals, free UDP ports, a socket in its data folder.
# The script stops at once, before installing anything, if one of its ports is taken.
set -euo pipefail
PORT=${PORT:-8000}
BOAT_PORT=${BOAT_PORT:-14550}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
"${PYTHON:-python3}" "$here/netcheck.py" free "PORT=tcp:$PORT" "BOAT_PORT=udp:$BOAT_PORT" \
  "BOAT_PORT+10=udp:$((BOAT_PORT + 10))"
source "$here/bootstrap.sh"
default_data=$(cd .. && pwd)/shoreside-data
export SHORESIDE_DATA_DIR=${SHORESIDE_DATA_DIR:-$default_data}
export WHITENOISE_USE_FINDERS=0
(umask 077; mkdir -p "$SHORESIDE_DATA_DIR")  # private: keys, the database, the modem socket
data=$(cd "$SHORESIDE_DATA_DIR" && pwd)
py=.venv/bin/python
say() { echo "demo: $*"; }

pids=()
stop_all() {
  trap '' INT TERM  # a second Ctrl-C must not cut the clean stop short
  trap - EXIT
  ((${#pids[@]})) || return 0
  say "stopping…"
  kill -TERM "${pids[@]}" 2>/dev/null || true
  # Each stops its own children (gunicorn its workers, a boat or the glider its processes):
  # give them 30 s, then kill what is left and its children.
  for _ in $(seq 300); do
    local left=0 pid
    for pid in "${pids[@]}"; do kill -0 "$pid" 2>/dev/null && left=1; done
    ((left)) || break
    sleep 0.1
  done
  for pid in "${pids[@]}"; do
    if kill -0 "$pid" 2>/dev/null; then
      say "pid $pid did not stop; killing it"
      pkill -KILL -P "$pid" 2>/dev/null || true
      kill -KILL "$pid" 2>/dev/null || true
    fi
  done
  wait 2>/dev/null || true
  say "stopped"
}
trap 'stop_all; exit 130' INT
trap 'stop_all; exit 143' TERM
trap stop_all EXIT

say "migrating…"
$py manage.py migrate --noinput -v0
say "collecting static files…"
$py manage.py collectstatic --noinput -v0
say "seeding the demo fleet…"
$py manage.py seed_demo >"$data/seed.log"
login=$(sed -n 's/.*Log in at .* as *\(user: .*\)$/\1/p' "$data/seed.log")
keys="$data/demo-keys.json"
# Each vessel's key in a private file of its own: on the command line it would show in `ps`.
key_file() {
  (umask 077; $py -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" \
    "$keys" "$1" >"$data/key-$1")
  echo "$data/key-$1"
}
server="http://127.0.0.1:$PORT"

say "starting the site…"
$py -m gunicorn fleet.wsgi -b "127.0.0.1:$PORT" -w 2 --threads 4 >"$data/site.log" 2>&1 &
pids+=($!)
site=$!
# Keeps the maps' track overview built as the vessels report (map reads never write).
$py manage.py rebuild_track_overview --loop --interval 5 >"$data/overview.log" 2>&1 &
pids+=($!)
# Watches the fleet: the seeded alert rules (overdue, battery, hull humidity) open and resolve
# alerts, and their notifications are sent from here.
$py manage.py run_alerts >"$data/alerts.log" 2>&1 &
pids+=($!)
if ! $py scripts/netcheck.py answers "$server/admin/login/" --pid "$site" --timeout 120; then
  say "the site did not start; its log ($data/site.log) ends:"
  tail -n 20 "$data/site.log" >&2
  exit 1
fi

# Wait (up to a minute) for a vessel's line saying it started; stop the demo if it ended.
started() {  # pid log what-it-says name
  for _ in $(seq 600); do
    grep -q "$3" "$2" 2>/dev/null && return 0
    if ! kill -0 "$1" 2>/dev/null; then
      say "$4 did not start; its log ($2) ends:"
      tail -n 20 "$2" >&2
      exit 1
    fi
    sleep 0.1
  done
  say "$4 is slow to start (see $2)"
}

# Each vessel's log is new: `started` must not read the line of a previous run.
rm -f "$data/sim-spab.log" "$data/sim-spab-2.log" "$data/sim-glider.log"
say "starting boats…"
$py manage.py simulate_boat --server "$server" --key-file "$(key_file spab)" \
  --start=-32.0200,115.7000 --port "$BOAT_PORT" >"$data/sim-spab.log" 2>&1 &
pids+=($!)
boat1=$!
$py manage.py simulate_boat --server "$server" --key-file "$(key_file spab-2)" \
  --start=-32.0500,115.6800 --port "$((BOAT_PORT + 10))" >"$data/sim-spab-2.log" 2>&1 &
pids+=($!)
boat2=$!

say "starting the glider bridge…"
# The glider is a Shoreside of its own (as on its Pi): its own folder and SQLite database.
SHORESIDE_DATA_DIR="$data/glider" env -u DATABASE_URL $py manage.py simulate_glider \
  --server "$server" --key-file "$(key_file glider)" --start=-32.0800,115.7000 \
  >"$data/sim-glider.log" 2>&1 &
pids+=($!)
started "$boat1" "$data/sim-spab.log" "^boat at" "the boat spab"
started "$boat2" "$data/sim-spab-2.log" "^boat at" "the boat spab-2"
started "$!" "$data/sim-glider.log" "glider at .* bridge pid" "the glider"

sms_cmd="$PWD/.venv/bin/python $PWD/manage.py demo_sms"
if [ "$data" != "$default_data" ]; then
  sms_cmd="SHORESIDE_DATA_DIR=$data $sms_cmd"
fi
cat <<EOF

Shoreside demo: two Rover boats and a Wave Glider off Fremantle, live.
  Text the glider (from another terminal; +61400000001 may command it):
    $sms_cmd "+61400000001" "#FHEAD 230"
  Logs: $data/*.log    Ctrl-C stops the demo.

Open $server/admin/ and log in as  $login
EOF
wait "$site"
say "the site stopped; its log ($data/site.log) ends:"
tail -n 20 "$data/site.log" >&2
exit 1
