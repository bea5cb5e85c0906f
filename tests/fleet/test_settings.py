"""Settings helpers and the production-safety system checks (fleet/settings.py, checks.py)."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from django.core import checks as django_checks
from django.core.management import call_command

from fleet.checks import check_production_safety
from fleet.settings import database_from_url, env_bool, env_int, env_list, env_rate

ROOT = Path(__file__).resolve().parents[2]
LONG_KEY = "k" * 50


# --- env helpers ---


@pytest.mark.parametrize("raw", ["1", "true", "TRUE", "Yes", "on", " on "])
def test_env_bool_reads_yes(monkeypatch: pytest.MonkeyPatch, raw: str) -> None:
    monkeypatch.setenv("X_FLAG", raw)
    assert env_bool("X_FLAG", False) is True


@pytest.mark.parametrize("raw", ["0", "false", "No", "OFF", ""])
def test_env_bool_reads_no(monkeypatch: pytest.MonkeyPatch, raw: str) -> None:
    monkeypatch.setenv("X_FLAG", raw)
    assert env_bool("X_FLAG", True) is False


@pytest.mark.parametrize("raw", ["2", "maybe", "y", "n", "True!", "enable", "-1"])
def test_env_bool_refuses_to_guess(monkeypatch: pytest.MonkeyPatch, raw: str) -> None:
    monkeypatch.setenv("X_FLAG", raw)
    with pytest.raises(ValueError, match=r"X_FLAG=.* is not a boolean"):
        env_bool("X_FLAG", False)


def test_env_helpers_fall_back_to_the_default(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("X_FLAG", raising=False)
    assert env_bool("X_FLAG", True) is True
    assert env_int("X_FLAG", 7) == 7
    assert env_list("X_FLAG", ["a"]) == ["a"]
    monkeypatch.setenv("X_FLAG", "  ")
    assert env_int("X_FLAG", 7) == 7


@pytest.mark.parametrize(("raw", "value"), [("42", 42), (" 42 ", 42), ("-3", -3), ("0", 0)])
def test_env_int_reads_integers(monkeypatch: pytest.MonkeyPatch, raw: str, value: int) -> None:
    monkeypatch.setenv("X_NUM", raw)
    assert env_int("X_NUM", 1) == value


@pytest.mark.parametrize("raw", ["ten", "1.5", "1e3", "0x10", "60s"])
def test_env_int_refuses_anything_else(monkeypatch: pytest.MonkeyPatch, raw: str) -> None:
    monkeypatch.setenv("X_NUM", raw)
    with pytest.raises(ValueError, match=r"X_NUM=.* is not an integer"):
        env_int("X_NUM", 1)


def test_env_list_splits_on_commas(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("X_HOSTS", "a.example, b.example,,")
    assert env_list("X_HOSTS", []) == ["a.example", "b.example"]


# --- DATABASE_URL ---


def test_database_from_a_postgres_url() -> None:
    db = database_from_url("postgres://fleet:p%40ss@db.example:6543/shore?sslmode=require")
    assert db["ENGINE"] == "django.db.backends.postgresql"
    assert (db["NAME"], db["USER"], db["PASSWORD"]) == ("shore", "fleet", "p@ss")
    assert (db["HOST"], db["PORT"]) == ("db.example", "6543")
    assert db["OPTIONS"] == {"sslmode": "require"}


@pytest.mark.parametrize("scheme", ["postgres", "postgresql", "pgsql"])
def test_database_url_scheme_aliases(scheme: str) -> None:
    db = database_from_url(f"{scheme}://postgres@127.0.0.1/x")
    assert db["ENGINE"] == "django.db.backends.postgresql"
    assert (db["USER"], db["PASSWORD"], db["PORT"]) == ("postgres", "", "")


def test_database_from_a_sqlite_url() -> None:
    db = database_from_url("sqlite:////var/lib/shoreside/db.sqlite3")
    assert db["ENGINE"] == "django.db.backends.sqlite3"
    assert db["NAME"] == Path("/var/lib/shoreside/db.sqlite3")
    assert "journal_mode=WAL" in db["OPTIONS"]["init_command"]
    assert "busy_timeout" in db["OPTIONS"]["init_command"]


@pytest.mark.parametrize("url", ["mysql://u@h/db", "redis://h", "nonsense"])
def test_an_unsupported_database_url_is_refused(url: str) -> None:
    with pytest.raises(ValueError, match="not supported"):
        database_from_url(url)


@pytest.mark.parametrize(
    ("url", "scheme"), [("mysql://u@h/db", "mysql"), ("oracle://h/x", "oracle")]
)
def test_the_refusal_names_the_scheme(url: str, scheme: str) -> None:
    # dj-database-url itself would parse these; Shoreside runs on PostgreSQL and SQLite only.
    with pytest.raises(ValueError, match=f"DATABASE_URL scheme '{scheme}' is not supported"):
        database_from_url(url)


@pytest.mark.parametrize("url", ["postgres://u@h/db", "sqlite:////var/lib/shore.db"])
def test_database_urls_keep_connections_with_health_checks(
    monkeypatch: pytest.MonkeyPatch, url: str
) -> None:
    monkeypatch.setenv("DB_CONN_MAX_AGE", "42")
    db = database_from_url(url)
    assert (db["CONN_MAX_AGE"], db["CONN_HEALTH_CHECKS"]) == (42, True)
    monkeypatch.delenv("DB_CONN_MAX_AGE")
    assert database_from_url(url)["CONN_MAX_AGE"] == 600


def test_a_sqlite_url_gets_the_default_sqlite_options() -> None:
    db = database_from_url("sqlite:////var/lib/shoreside/db.sqlite3")
    assert db["OPTIONS"]["timeout"] == 20
    assert db["OPTIONS"]["transaction_mode"] == "IMMEDIATE"
    assert "foreign_keys=ON" in db["OPTIONS"]["init_command"]
    assert db["TEST"]["NAME"] == Path(f"/var/lib/shoreside/test_{os.getpid()}_db.sqlite3")


def test_a_postgres_url_without_options_still_has_an_options_table() -> None:
    assert database_from_url("postgres://u@h:5433/db")["OPTIONS"] == {}
    assert database_from_url("postgres://u@h:5433/db")["PORT"] == "5433"


def test_the_default_timezone_is_utc(settings: Any) -> None:
    assert settings.TIME_ZONE == "UTC"
    assert settings.USE_TZ is True


# --- production safety checks ---


def ids() -> set[str]:
    return {problem.id for problem in check_production_safety()}


def safe_production(settings: Any) -> None:
    settings.PRODUCTION = True
    settings.DEBUG = False
    settings.SECRET_KEY = LONG_KEY
    settings.SESSION_COOKIE_SECURE = True
    settings.CSRF_COOKIE_SECURE = True
    settings.SECURE_SSL_REDIRECT = True
    settings.ALLOWED_HOSTS = ["shoreside.example"]


def test_a_safe_production_setup_passes(settings: Any) -> None:
    safe_production(settings)
    assert ids() == set()


def test_local_development_passes(settings: Any) -> None:
    settings.PRODUCTION = False
    settings.DEBUG = True
    settings.ALLOWED_HOSTS = ["localhost", "127.0.0.1", "[::1]"]
    assert ids() == set()


def test_e001_debug_with_public_hosts(settings: Any) -> None:
    settings.PRODUCTION = False
    settings.DEBUG = True
    settings.ALLOWED_HOSTS = ["localhost", "shoreside.example"]
    assert ids() == {"fleet.E001", "fleet.W002"}


def test_w002_public_hosts_without_production(settings: Any) -> None:
    settings.PRODUCTION = False
    settings.DEBUG = False
    settings.ALLOWED_HOSTS = ["*"]
    problems = check_production_safety()
    assert [p.id for p in problems] == ["fleet.W002"]
    assert problems[0].level == django_checks.WARNING


@pytest.mark.parametrize(
    ("setting", "value", "problem"),
    [
        ("SECRET_KEY", "short", "fleet.E002"),
        ("DEBUG", True, "fleet.E003"),
        ("SESSION_COOKIE_SECURE", False, "fleet.E004"),
        ("CSRF_COOKIE_SECURE", False, "fleet.E004"),
        ("ALLOWED_HOSTS", [], "fleet.E005"),
        ("ALLOWED_HOSTS", ["*"], "fleet.E005"),
        ("SECURE_SSL_REDIRECT", False, "fleet.W001"),
    ],
)
def test_each_unsafe_production_setting_is_reported(
    settings: Any, setting: str, value: Any, problem: str
) -> None:
    safe_production(settings)
    setattr(settings, setting, value)
    found = ids()
    assert problem in found
    # DEBUG with a public host also trips E001; nothing else should fire.
    assert found <= {problem, "fleet.E001"}


def test_the_errors_are_errors_with_hints(settings: Any) -> None:
    safe_production(settings)
    settings.DEBUG = True
    settings.SECRET_KEY = "short"
    for problem in check_production_safety():
        assert problem.hint
        assert problem.level == (
            django_checks.WARNING if problem.id.startswith("fleet.W") else django_checks.ERROR
        )


def test_manage_py_check_fails_on_an_unsafe_combination(settings: Any) -> None:
    safe_production(settings)
    settings.DEBUG = True
    from django.core.management.base import SystemCheckError

    with pytest.raises(SystemCheckError, match="fleet.E003"):
        call_command("check")


# --- importing the settings module itself ---


def _import_settings(tmp_path: Path, **env: str) -> subprocess.CompletedProcess[str]:
    clean = {k: v for k, v in os.environ.items() if k not in {"SECRET_KEY", "PRODUCTION", "DEBUG"}}
    clean.update(SHORESIDE_DATA_DIR=str(tmp_path / "data"), **env)
    return subprocess.run(
        [sys.executable, "-c", "import fleet.settings as s; print(s.DEBUG, s.SECURE_SSL_REDIRECT)"],
        cwd=ROOT,
        env=clean,
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_production_without_a_secret_key_refuses_to_start(tmp_path: Path) -> None:
    result = _import_settings(tmp_path, PRODUCTION="1")
    assert result.returncode != 0
    assert "ImproperlyConfigured" in result.stderr
    assert "SECRET_KEY must be set in the environment when PRODUCTION=1" in result.stderr
    assert not (tmp_path / "data" / "secret_key").exists()


def test_production_with_a_secret_key_has_safe_defaults(tmp_path: Path) -> None:
    result = _import_settings(tmp_path, PRODUCTION="1", SECRET_KEY=LONG_KEY)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["False", "True"]


def test_local_use_generates_and_keeps_a_secret_key(tmp_path: Path) -> None:
    first = _import_settings(tmp_path)
    assert first.returncode == 0, first.stderr
    key_file = tmp_path / "data" / "secret_key"
    key = key_file.read_text()
    assert len(key) >= 50
    assert oct(key_file.stat().st_mode & 0o777) == "0o600"
    assert _import_settings(tmp_path).returncode == 0
    assert key_file.read_text() == key


def test_an_ambiguous_flag_stops_the_settings_import(tmp_path: Path) -> None:
    result = _import_settings(tmp_path, DEBUG="sometimes")
    assert result.returncode != 0
    assert "DEBUG='sometimes' is not a boolean" in result.stderr


def test_e006_sqlite_too_old_for_the_fix_ingest(monkeypatch: pytest.MonkeyPatch) -> None:
    # The fix ingest's INSERT … RETURNING needs SQLite 3.35; Django itself runs on 3.31.
    import fleet.checks

    assert not fleet.checks.check_sqlite_version()  # this machine's database
    sqlite = {"default": {"ENGINE": "django.db.backends.sqlite3"}}
    monkeypatch.setattr(fleet.checks, "settings", SimpleNamespace(DATABASES=sqlite))
    assert not fleet.checks.check_sqlite_version()  # this machine's SQLite
    monkeypatch.setattr(fleet.checks.sqlite3, "sqlite_version_info", (3, 34, 1))
    problems = fleet.checks.check_sqlite_version()
    assert [p.id for p in problems] == ["fleet.E006"]
    assert "3.34.1" in problems[0].msg
    postgres = {"default": {"ENGINE": "django.db.backends.postgresql"}}
    monkeypatch.setattr(fleet.checks, "settings", SimpleNamespace(DATABASES=postgres))
    assert not fleet.checks.check_sqlite_version()


def test_sqlite_urls_read_like_dj_database_url() -> None:
    from pathlib import Path

    from fleet.settings import database_from_url

    assert database_from_url("sqlite:////var/lib/shore.db")["NAME"] == Path("/var/lib/shore.db")
    assert database_from_url("sqlite:///shore.db")["NAME"] == Path("shore.db")


def test_the_generated_secret_key_file_is_private_from_the_start(tmp_path) -> None:
    from fleet.files import write_private

    path = tmp_path / "secret_key"
    write_private(path, "s3cret")
    assert path.read_text() == "s3cret"
    assert oct(path.stat().st_mode & 0o777) == "0o600"


def test_legacy_endpoints_stay_on_plain_http_under_the_https_redirect(client, settings) -> None:
    settings.SECURE_SSL_REDIRECT = True
    assert client.get("/admin/login/").status_code == 301
    assert client.get("/spab/requestCommands.cgi").status_code == 401  # answered, not redirected


def test_production_with_debug_refuses_to_start(tmp_path: Path) -> None:
    # fleet.E003 alone is not enough: gunicorn runs no system checks.
    result = _import_settings(
        tmp_path, PRODUCTION="1", DEBUG="1", SECRET_KEY=LONG_KEY, ALLOWED_HOSTS="shore.example"
    )
    assert result.returncode != 0
    assert "ImproperlyConfigured" in result.stderr
    assert "DEBUG=1 and PRODUCTION=1 together" in result.stderr


def test_the_sqlite_database_and_data_folder_are_private(tmp_path: Path) -> None:
    # A fresh data dir, migrated under the usual umask 022, then a connection held open so
    # SQLite's -wal and -shm files exist while their modes are read.
    data = tmp_path / "data"
    env = {k: v for k, v in os.environ.items() if k not in {"DATABASE_URL", "SECRET_KEY"}}
    env.update(SHORESIDE_DATA_DIR=str(data), PRODUCTION="0", DEBUG="0")
    umask = {"preexec_fn": lambda: os.umask(0o022)}
    migrate = subprocess.run(
        [sys.executable, "manage.py", "migrate", "--verbosity", "0"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=120, **umask,
    )  # fmt: skip
    assert migrate.returncode == 0, migrate.stderr
    show_modes = (
        "from django.db import connection; import os, stat\n"
        "connection.cursor().execute('SELECT count(*) FROM django_migrations')\n"
        "for name in sorted(os.listdir(os.environ['SHORESIDE_DATA_DIR'])):\n"
        "    path = os.path.join(os.environ['SHORESIDE_DATA_DIR'], name)\n"
        "    if os.path.isfile(path):\n"
        "        print('mode', name, oct(stat.S_IMODE(os.stat(path).st_mode)))\n"
    )
    held = subprocess.run(
        [sys.executable, "manage.py", "shell", "-c", show_modes],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=120, **umask,
    )  # fmt: skip
    assert held.returncode == 0, held.stderr
    modes = dict(line.split()[1:] for line in held.stdout.splitlines() if line.startswith("mode "))
    assert set(modes) >= {
        "secret_key",
        "shoreside.sqlite3",
        "shoreside.sqlite3-wal",
        "shoreside.sqlite3-shm",
    }
    assert set(modes.values()) == {"0o600"}, modes
    assert oct(stat.S_IMODE(data.stat().st_mode)) == "0o700"


@pytest.mark.parametrize(
    ("raw", "rate"),
    [("600/min", "600/min"), (" 20/S ", "20/s"), ("5000/day", "5000/day"), ("off", None)],
)
def test_env_rate_reads_rates(monkeypatch: pytest.MonkeyPatch, raw: str, rate: str | None) -> None:
    monkeypatch.setenv("X_RATE", raw)
    assert env_rate("X_RATE", "1/s") == rate


@pytest.mark.parametrize("raw", ["600", "600/minutes", "10/fortnight", "-1/s", "1.5/s", "none"])
def test_env_rate_refuses_anything_else(monkeypatch: pytest.MonkeyPatch, raw: str) -> None:
    monkeypatch.setenv("X_RATE", raw)
    with pytest.raises(ValueError, match=r"X_RATE=.* is not a rate"):
        env_rate("X_RATE", "1/s")


def _settings_value(tmp_path: Path, expr: str, **env: str) -> subprocess.CompletedProcess[str]:
    clean = {k: v for k, v in os.environ.items() if k not in {"CACHE_BACKEND", "PRODUCTION"}}
    clean.update(SHORESIDE_DATA_DIR=str(tmp_path / "data"), **env)
    return subprocess.run(
        [sys.executable, "-c", f"import fleet.settings as s; print({expr})"],
        cwd=ROOT, env=clean, capture_output=True, text=True, timeout=60,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("backend", "expected"),
    [("", "LocMemCache"), ("file", "FileBasedCache"), ("database", "DatabaseCache")],
)
def test_the_cache_backend_comes_from_the_environment(
    tmp_path: Path, backend: str, expected: str
) -> None:
    result = _settings_value(tmp_path, "s.CACHES['default']['BACKEND']", CACHE_BACKEND=backend)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().endswith(expected)


def test_an_unknown_cache_backend_stops_the_settings_import(tmp_path: Path) -> None:
    result = _settings_value(tmp_path, "s.CACHES", CACHE_BACKEND="redis")
    assert result.returncode != 0
    assert "CACHE_BACKEND='redis' is not one of locmem, file, database" in result.stderr


def test_throttle_rates_come_from_the_environment(tmp_path: Path) -> None:
    rates = "s.REST_FRAMEWORK['DEFAULT_THROTTLE_RATES']"
    result = _settings_value(
        tmp_path, rates, THROTTLE_BOAT_RATE="5/s", THROTTLE_OPERATOR_RATE="off"
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "{'boat': '5/s', 'operator': None}"


# --- fleet.W003: the data folder and its secrets are the service user's alone ---


def _private_data(tmp_path: Path) -> tuple[Path, Path, Path]:
    data = tmp_path / "data"
    data.mkdir(mode=0o700)
    db, secret = data / "shoreside.sqlite3", data / "secret_key"
    for path in (db, secret):
        path.touch(mode=0o600)
    return data, db, secret


def _w003(monkeypatch: pytest.MonkeyPatch, data: Path, db: Path) -> list[str]:
    import fleet.checks

    sqlite = {"default": {"ENGINE": "django.db.backends.sqlite3", "NAME": db}}
    monkeypatch.setattr(fleet.checks, "settings", SimpleNamespace(DATA_DIR=data, DATABASES=sqlite))
    problems = fleet.checks.check_data_permissions()
    assert {p.id for p in problems} <= {"fleet.W003"}
    return [p.msg for p in problems]


def test_w003_is_quiet_for_a_private_data_folder(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    data, db, _ = _private_data(tmp_path)
    assert _w003(monkeypatch, data, db) == []


@pytest.mark.parametrize(
    ("name", "mode"),
    [("", 0o755), ("", 0o750), ("", 0o701), ("shoreside.sqlite3", 0o644),
     ("shoreside.sqlite3", 0o620), ("secret_key", 0o640), ("shoreside.sqlite3-wal", 0o604)],
)  # fmt: skip
def test_w003_names_what_others_may_read_or_write(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, name: str, mode: int
) -> None:
    data, db, _ = _private_data(tmp_path)
    path = data / name
    path.touch(mode=0o600, exist_ok=True)
    path.chmod(mode)
    assert _w003(monkeypatch, data, db) == [f"{path} is open to other users (mode {mode:04o})."]


def test_w003_skips_what_does_not_exist(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    data, db, secret = _private_data(tmp_path)
    secret.unlink()
    assert _w003(monkeypatch, data, data / "elsewhere.sqlite3") == []


def test_manage_py_check_warns_about_an_open_data_folder(tmp_path: Path) -> None:
    data = tmp_path / "data"
    data.mkdir()
    data.chmod(0o755)  # an older folder, made before Shoreside created it 0700
    env = {k: v for k, v in os.environ.items() if k not in {"DATABASE_URL", "SECRET_KEY"}}
    env["SHORESIDE_DATA_DIR"] = str(data)

    def check() -> str:
        done = subprocess.run([sys.executable, "manage.py", "check"], cwd=ROOT, env=env,
                              capture_output=True, text=True, timeout=120)  # fmt: skip
        assert done.returncode == 0, done.stderr
        return done.stdout + done.stderr

    output = check()
    assert f"(fleet.W003) {data} is open to other users (mode 0755)." in output
    assert f"HINT: chmod 700 {data}" in output
    data.chmod(0o700)
    assert "fleet.W003" not in check()
