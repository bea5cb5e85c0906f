# Sourced by the other scripts: make .venv (Python 3.11+) and install the project into it.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
PYTHON=${PYTHON:-python3}
if ! "$PYTHON" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
  echo "Shoreside needs Python 3.11 or newer ($PYTHON is $("$PYTHON" --version 2>&1))" >&2
  exit 1
fi
# Reinstall only when the dependency list changed since the last install.
stamp=.venv/.shoreside-installed
if [ ! -x .venv/bin/python ] || [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  # One line, on stderr: the scripts' own output (test.sh's, demo.sh's) stays as it was.
  echo "installing dependencies into .venv… (a minute or two the first time)" >&2
fi
if [ ! -x .venv/bin/python ]; then
  "$PYTHON" -m venv .venv
fi
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  # pip's warnings go to a log, not between the scripts' lines; a failure shows its end.
  if ! { .venv/bin/python -m pip install --quiet --upgrade pip &&
    .venv/bin/python -m pip install --quiet -e '.[dev]'; } >.venv/install.log 2>&1; then
    echo "installing the dependencies failed; the end of .venv/install.log:" >&2
    tail -n 30 .venv/install.log >&2
    exit 1
  fi
  touch "$stamp"
fi
