#!/usr/bin/env bash
# One command for the demo: install, migrate, seed a demo fleet, start two simulated boats and
# serve the site on http://127.0.0.1:${PORT:-8000}/ (SQLite; no other service needed).
# Each boat is the real edge client driving the Rover MAVLink simulator (manage.py simulate_boat),
# at its own start position and on its own UDP port.
source "$(dirname "${BASH_SOURCE[0]}")/bootstrap.sh"
PORT=${PORT:-8000}
BOAT_PORT=${BOAT_PORT:-14550}  # UDP port of the first boat's simulator; the second uses +10
export SHORESIDE_DATA_DIR=${SHORESIDE_DATA_DIR:-$PWD/../shoreside-data}
export WHITENOISE_USE_FINDERS=0
py=.venv/bin/python
$py manage.py migrate --noinput -v0
$py manage.py collectstatic --noinput -v0
$py manage.py seed_demo
keys="$SHORESIDE_DATA_DIR/demo-keys.json"
# Each boat's key in a private file of its own: on the command line it would show in `ps`.
key_file() {
  (umask 077; $py -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" \
    "$keys" "$1" >"$SHORESIDE_DATA_DIR/key-$1")
  echo "$SHORESIDE_DATA_DIR/key-$1"
}
pids=()
cleanup() { kill "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; }
trap cleanup EXIT INT TERM
$py -m gunicorn fleet.wsgi -b "127.0.0.1:$PORT" -w 2 --threads 4 &
pids+=($!)
# Keeps the maps' track overview built as the boats report (map reads never write).
$py manage.py rebuild_track_overview --loop --interval 5 >"$SHORESIDE_DATA_DIR/overview.log" 2>&1 &
pids+=($!)
sleep 2
$py manage.py simulate_boat --server "http://127.0.0.1:$PORT" --key-file "$(key_file spab)" \
  --start=-31.9790,115.8170 --port "$BOAT_PORT" >"$SHORESIDE_DATA_DIR/sim-spab.log" 2>&1 &
pids+=($!)
$py manage.py simulate_boat --server "http://127.0.0.1:$PORT" --key-file "$(key_file spab-2)" \
  --start=-32.0560,115.7400 --port "$((BOAT_PORT + 10))" >"$SHORESIDE_DATA_DIR/sim-spab-2.log" 2>&1 &
pids+=($!)
echo "Shoreside demo on http://127.0.0.1:$PORT/admin/ (Ctrl-C stops it; boat logs in $SHORESIDE_DATA_DIR)"
wait "${pids[0]}"
