#!/usr/bin/env bash
# One command for the tests: install, then run the whole suite (extra arguments go to pytest).
# SQLite by default; set DATABASE_URL=postgres://… to run the same suite on PostgreSQL.
source "$(dirname "${BASH_SOURCE[0]}")/bootstrap.sh"
export SHORESIDE_DATA_DIR=${SHORESIDE_DATA_DIR:-$(mktemp -d)}
exec .venv/bin/python -m pytest "$@"
