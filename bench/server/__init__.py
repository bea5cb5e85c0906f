"""Issue-2 speed benchmark: the real stack (gunicorn + Django) under wrk, beside baselines.

    python -m bench.server                   # full run, SQLite (WAL) then PostgreSQL
    python -m bench.server --quick --db sqlite
    python -m bench.server --soak-seconds 60 --worker-class sync
    python -m bench.server --profile /tmp/prof --db sqlite   # cProfile every worker request
    python -m bench.server --quick --single-only --rounds 4  # single posts vs DRF, ~1 min/db

For each database: a fresh data dir (SQLite) or a throwaway database (PostgreSQL), migrated;
gunicorn with 2 workers on 127.0.0.1 serving `bench.settings` (production settings + the
baseline routes of bench.baseline); load from wrk (Lua scripts in bench/lua) and from a small
asyncio client for the 200-boat mixed run. Every figure is printed beside the baselines measured
in the same run and the issue's target. Servers, data dir and database are removed on exit,
also on Ctrl-C. Only 127.0.0.1 is ever contacted.

Single-fix posts (ours against the DRF baseline) run in interleaved rounds, ours, DRF, DRF,
ours… (``--rounds``), so a load that comes and goes on a shared machine falls on both; the
ratio is printed per round and over all rounds. Compare ratios, not rates, on a busy machine.
Each wrk connection of those rounds posts as a boat of its own (its own vessel and key, one wrk
thread per connection), on both sides alike: a fleet's boats each post their own fixes, while N
connections posting for one boat queued on that boat's rows (its last fix, its overview minute),
which no fleet does. The DRF baseline does the same work as before (parse, validate, insert).

One job per module: ``constants`` (targets, load shape, URLs), ``stack`` (data dir or throwaway
database, migrate, provision, gunicorn, cleanup), ``helper`` (the Django side, in a subprocess),
``client``/``wrk``/``fixes``/``mixed`` (load generation), ``phases`` (the measured phases),
``report`` (the figures table) and ``cli`` (arguments and the run per database).
"""
