.PHONY: demo test test-pg lint bench

demo:            ## run the site with a demo fleet and two simulated boats (SQLite)
	bash scripts/demo.sh

test:            ## the whole test suite on SQLite
	bash scripts/test.sh

test-pg:         ## the same suite on the local PostgreSQL
	createdb -h 127.0.0.1 -U postgres shoreside_dev 2>/dev/null || true
	DATABASE_URL=postgres://postgres@127.0.0.1:5432/shoreside_dev bash scripts/test.sh

lint:
	.venv/bin/ruff check . && .venv/bin/ruff format --check .
	.venv/bin/python manage.py makemigrations --check --dry-run

bench:           ## server, maps, Level 2, compact fixes, SMS, bridge, edge client, notification, SBD webhook, retention and alerts benchmarks, each against an in-run baseline
	.venv/bin/python -m bench.server
	.venv/bin/python -m bench.maps --postgres
	.venv/bin/python -m bench.level2
	.venv/bin/python -m bench.compact
	.venv/bin/python -m bench.sms
	.venv/bin/python -m bench.bridge
	.venv/bin/python -m bench.wg_bridge
	.venv/bin/python -m bench.edge
	.venv/bin/python -m bench.notify
	.venv/bin/python -m bench.sbd
	.venv/bin/python -m bench.retention --postgres
	.venv/bin/python -m bench.alerts --postgres
