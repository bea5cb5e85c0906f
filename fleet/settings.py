"""Shoreside settings: one module, driven by the environment (see .env.example).

SQLite in a data folder outside the source tree by default; PostgreSQL when DATABASE_URL is set.
Production safety is enforced by the system checks in fleet/checks.py.
"""

from __future__ import annotations

import ipaddress
import os
import re
import secrets
from pathlib import Path
from urllib.parse import urlsplit

import dj_database_url
import phonenumbers
from django.core.exceptions import ImproperlyConfigured

from fleet.files import create_private, write_private

BASE_DIR = Path(__file__).resolve().parent.parent

_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off", ""}


def env_bool(name: str, default: bool) -> bool:
    """Read a boolean; anything but a clear yes/no is an error rather than a guess."""
    raw = os.environ.get(name)
    if raw is None:
        return default
    value = raw.strip().lower()
    if value in _TRUE:
        return True
    if value in _FALSE:
        return False
    raise ValueError(f"{name}={raw!r} is not a boolean (use 1/0, true/false, yes/no, on/off)")


def env_int(name: str, default: int) -> int:
    raw = os.environ.get(name)
    if raw is None or raw.strip() == "":
        return default
    try:
        return int(raw)
    except ValueError:
        raise ValueError(f"{name}={raw!r} is not an integer") from None


def env_float(name: str, default: float) -> float:
    raw = os.environ.get(name)
    if raw is None or raw.strip() == "":
        return default
    try:
        return float(raw)
    except ValueError:
        raise ValueError(f"{name}={raw!r} is not a number") from None


def env_rate(name: str, default: str) -> str | None:
    """A request rate in DRF's form (`600/min`: per s, min, hour or day), or `off` (None)."""
    raw = os.environ.get(name)
    value = default if raw is None or not raw.strip() else raw.strip().lower()
    if value == "off":
        return None
    if not re.fullmatch(r"\d+/(s|sec|second|m|min|minute|h|hour|d|day)", value):
        raise ValueError(f"{name}={raw!r} is not a rate (e.g. 600/min, 20/s, 5000/day, or off)")
    return value


def env_list(name: str, default: list[str]) -> list[str]:
    raw = os.environ.get(name)
    if raw is None:
        return default
    return [item.strip() for item in raw.split(",") if item.strip()]


# The databases Shoreside runs on; dj-database-url would also accept mysql://, oracle://, ….
DATABASE_SCHEMES = ("postgres", "postgresql", "pgsql", "sqlite")


def database_from_url(url: str) -> dict[str, object]:
    """A DATABASES entry for DATABASE_URL: dj-database-url parses, then the project's extras.

    postgres://user:pass@host:port/name?opt=v, or sqlite:///relative.db and
    sqlite:////absolute/path.db (which get the same options as the default SQLite file).
    """
    scheme = urlsplit(url).scheme
    if scheme not in DATABASE_SCHEMES:
        raise ValueError(f"DATABASE_URL scheme {scheme!r} is not supported (postgres or sqlite)")
    db: dict[str, object] = dict(
        dj_database_url.parse(
            url,
            # Persistent connections: a boat poll must not pay for a new connection.
            conn_max_age=env_int("DB_CONN_MAX_AGE", 600),
            conn_health_checks=True,
        )
    )
    if db["ENGINE"] == "django.db.backends.sqlite3":
        return _sqlite(Path(str(db["NAME"])))
    # dj-database-url gives an int port and leaves out empty OPTIONS; Django takes both
    # forms, and the entry keeps the shape it always had.
    db["PORT"] = str(db["PORT"])
    db.setdefault("OPTIONS", {})
    return db


def _sqlite(path: Path) -> dict[str, object]:
    return {
        "ENGINE": "django.db.backends.sqlite3",
        "NAME": path,
        # Reconnecting per request would re-run the PRAGMAs below on every boat poll.
        "CONN_MAX_AGE": env_int("DB_CONN_MAX_AGE", 600),
        "CONN_HEALTH_CHECKS": True,
        "OPTIONS": {
            # Seconds a writer waits for the lock before "database is locked".
            "timeout": 20,
            # IMMEDIATE takes the write lock at BEGIN, so two workers never deadlock on upgrade.
            "transaction_mode": "IMMEDIATE",
            # WAL lets readers (the map, the admin) run while a boat's batch is written.
            "init_command": (
                "PRAGMA journal_mode=WAL;"
                "PRAGMA synchronous=NORMAL;"
                "PRAGMA busy_timeout=20000;"
                "PRAGMA foreign_keys=ON;"
            ),
        },
        # A file (not :memory:) so live-server and concurrency tests see real SQLite locking;
        # per process, so two test runs on one machine never share it.
        "TEST": {"NAME": path.with_name(f"test_{os.getpid()}_{path.name}")},
    }


# Local data (SQLite file, generated secret key) lives outside the source tree.
DATA_DIR = Path(os.environ.get("SHORESIDE_DATA_DIR", BASE_DIR.parent / "shoreside-data")).resolve()
# Only the service's user may enter it: it holds the database and the generated secret key.
# (The mode applies when the folder is created; an existing folder is left as it is.)
DATA_DIR.mkdir(mode=0o700, parents=True, exist_ok=True)

DEBUG = env_bool("DEBUG", False)
# PRODUCTION=1 turns on HTTPS-only cookies and redirects and requires SECRET_KEY. Without it
# ALLOWED_HOSTS defaults to this machine only, so a forgotten variable fails closed (and
# fleet.W002 warns when non-local hosts are served without it).
PRODUCTION = env_bool("PRODUCTION", False)
if PRODUCTION and DEBUG:
    # fleet.E003 is only a system check, and gunicorn runs no checks: it would serve Django's
    # debug pages (settings, SQL, tracebacks) to the internet. Refuse to start instead.
    raise ImproperlyConfigured(
        "DEBUG=1 and PRODUCTION=1 together would show Django's debug pages to anyone: "
        "set DEBUG=0 on a production server."
    )


def _secret_key() -> str:
    key = os.environ.get("SECRET_KEY", "")
    if key:
        return key
    if PRODUCTION:
        raise ImproperlyConfigured(
            "SECRET_KEY must be set in the environment when PRODUCTION=1 "
            "(python -c 'import secrets; print(secrets.token_urlsafe(50))')."
        )
    DATA_DIR.mkdir(parents=True, exist_ok=True)
    path = DATA_DIR / "secret_key"
    if not path.exists():
        write_private(path, secrets.token_urlsafe(50))
    return path.read_text().strip()


SECRET_KEY = _secret_key()

ALLOWED_HOSTS = env_list(
    "ALLOWED_HOSTS", ["localhost", "127.0.0.1", "[::1]"] if not PRODUCTION else []
)
CSRF_TRUSTED_ORIGINS = env_list("CSRF_TRUSTED_ORIGINS", [])

INSTALLED_APPS = [
    # No autodiscover: see fleet.apps (django-leaflet's admin module needs GDAL).
    "django.contrib.admin.apps.SimpleAdminConfig",
    "django.contrib.auth",
    "django.contrib.contenttypes",
    "django.contrib.sessions",
    "django.contrib.messages",
    "django.contrib.staticfiles",
    "rest_framework",
    "knox",  # its token model is swapped for operators.OperatorToken
    "drf_spectacular",
    "drf_spectacular_sidecar",
    "leaflet",
    "audit",
    "operators",
    "vessels",
    "telemetry",
    "commands",
    "sms",
    "sbd",
    "links",
    "alerts",
    "fleet",
]

MIDDLEWARE = [
    # Trims the boat API's answers (vessels/middleware.py) and counts their bytes per vessel
    # as answered (links/http.py): outermost.
    "links.http.BoatApiMiddleware",
    "fleet.middleware.RejectNulMiddleware",
    "fleet.middleware.DatabaseUnavailableMiddleware",
    "django.middleware.security.SecurityMiddleware",
    # Serves the vendored front-end assets (Leaflet, Swagger UI) itself: no CDN, no internet.
    "whitenoise.middleware.WhiteNoiseMiddleware",
    # Django's own, which boat API requests pass by (vessels/middleware.py).
    "vessels.middleware.SessionMiddleware",
    "django.middleware.common.CommonMiddleware",
    "django.middleware.csrf.CsrfViewMiddleware",
    "vessels.middleware.AuthenticationMiddleware",
    # Who and from where, for the audit entries a request's services write (audit.context).
    "operators.middleware.AuditOriginMiddleware",
    "vessels.middleware.MessageMiddleware",
    "django.middleware.clickjacking.XFrameOptionsMiddleware",
]

ROOT_URLCONF = "fleet.urls"
WSGI_APPLICATION = "fleet.wsgi.application"

TEMPLATES = [
    {
        "BACKEND": "django.template.backends.django.DjangoTemplates",
        "DIRS": [BASE_DIR / "fleet" / "templates"],
        "APP_DIRS": True,
        "OPTIONS": {
            "context_processors": [
                "django.template.context_processors.request",
                "django.contrib.auth.context_processors.auth",
                "django.contrib.messages.context_processors.messages",
                "fleet.context_processors.maps",
            ],
        },
    },
]

if os.environ.get("DATABASE_URL"):
    DATABASES = {"default": database_from_url(os.environ["DATABASE_URL"])}
else:
    DATA_DIR.mkdir(parents=True, exist_ok=True)
    DATABASES = {"default": _sqlite(DATA_DIR / "shoreside.sqlite3")}

DEFAULT_AUTO_FIELD = "django.db.models.BigAutoField"

# SQLite creates a missing database file with the umask's mode (world-readable under 022) and
# gives its -wal and -shm files the database file's mode: create it private first (an empty
# file is an empty database).
for _db in DATABASES.values():
    if _db["ENGINE"] == "django.db.backends.sqlite3" and not str(_db["NAME"]).startswith(
        (":", "file:")
    ):
        create_private(Path(_db["NAME"]))

AUTH_PASSWORD_VALIDATORS = [
    {"NAME": "django.contrib.auth.password_validation.UserAttributeSimilarityValidator"},
    {"NAME": "django.contrib.auth.password_validation.MinimumLengthValidator"},
    {"NAME": "django.contrib.auth.password_validation.CommonPasswordValidator"},
]

LANGUAGE_CODE = "en-gb"
TIME_ZONE = "UTC"
# Times read "2026-11-25 14:03:27 UTC" across the admin (vessels/display.py's format).
FORMAT_MODULE_PATH = ["fleet.formats"]
USE_I18N = True
USE_TZ = True

STATIC_URL = "static/"
STATIC_ROOT = Path(os.environ.get("STATIC_ROOT", DATA_DIR / "static"))
STATIC_ROOT.mkdir(parents=True, exist_ok=True)  # WhiteNoise expects it even before collectstatic
STORAGES = {
    "default": {"BACKEND": "django.core.files.storage.FileSystemStorage"},
    # Hashed names after collectstatic, cached for ever (fleet/static_storage.py).
    "staticfiles": {"BACKEND": "fleet.static_storage.HashedStaticFiles"},
}
# Served with a year's cache: Django's hashed names (12 hex digits before the extension) and the
# offline coastline's cells, in a folder named after the hash of them all (vessels/static/
# vessels/vendor/naturalearth/README.md); both change name whenever they change.
WHITENOISE_IMMUTABLE_FILE_TEST = r"\.[0-9a-f]{12}\.[^/]+$|/vendor/naturalearth/[0-9a-f]{12}/"
# Without collectstatic (tests, a quick runserver) serve straight from the apps' folders.
WHITENOISE_USE_FINDERS = env_bool("WHITENOISE_USE_FINDERS", True)
LOGIN_URL = "admin:login"

# Production transport security; DEBUG/local development keeps plain HTTP usable.
SECURE_SSL_REDIRECT = env_bool("SECURE_SSL_REDIRECT", PRODUCTION)
# The original SPAB F2414 modem speaks plain TCP only and cannot follow a redirect to HTTPS: the
# legacy SPAB endpoints stay reachable over HTTP unless LEGACY_PLAIN_HTTP=0.
SECURE_REDIRECT_EXEMPT = [r"^spab/"] if env_bool("LEGACY_PLAIN_HTTP", True) else []
SESSION_COOKIE_SECURE = env_bool("SESSION_COOKIE_SECURE", PRODUCTION)
CSRF_COOKIE_SECURE = env_bool("CSRF_COOKIE_SECURE", PRODUCTION)
SECURE_HSTS_SECONDS = env_int("SECURE_HSTS_SECONDS", 31536000 if PRODUCTION else 0)
SECURE_CONTENT_TYPE_NOSNIFF = True
SESSION_COOKIE_HTTPONLY = True
X_FRAME_OPTIONS = "DENY"
BEHIND_TLS_PROXY = env_bool("BEHIND_TLS_PROXY", False)
if BEHIND_TLS_PROXY:
    SECURE_PROXY_SSL_HEADER = ("HTTP_X_FORWARDED_PROTO", "https")


def env_networks(name: str, default: list[str]) -> list[str]:
    """Comma-separated IP addresses or networks (`10.0.0.0/8`); a typo stops the start."""
    values = env_list(name, default)
    for value in values:
        try:
            ipaddress.ip_network(value, strict=False)
        except ValueError:
            raise ValueError(f"{name}: {value!r} is not an IP address or network") from None
    return values


# The proxies whose X-Forwarded-For is believed (operators/clients.py): a request from any
# other address is taken at its REMOTE_ADDR, whatever headers it carries. The TLS proxy
# usually runs on this machine.
TRUSTED_PROXIES = env_networks("TRUSTED_PROXIES", ["127.0.0.1", "::1"] if BEHIND_TLS_PROXY else [])

REST_FRAMEWORK = {
    "DEFAULT_AUTHENTICATION_CLASSES": [
        "rest_framework.authentication.SessionAuthentication",
        "operators.auth.OperatorTokenAuthentication",
    ],
    "DEFAULT_PERMISSION_CLASSES": ["vessels.permissions.ModelPermissions"],
    "DEFAULT_RENDERER_CLASSES": ["rest_framework.renderers.JSONRenderer"]
    + (["rest_framework.renderers.BrowsableAPIRenderer"] if DEBUG else []),
    "DEFAULT_PARSER_CLASSES": ["vessels.api.parsers.JSONParser"],
    "DEFAULT_PAGINATION_CLASS": "rest_framework.pagination.CursorPagination",
    "PAGE_SIZE": 500,
    "DEFAULT_SCHEMA_CLASS": "drf_spectacular.openapi.AutoSchema",
    "EXCEPTION_HANDLER": "fleet.api.exception_handler",
    # `?format=csv` is the exports' own parameter, not DRF content negotiation.
    "URL_FORMAT_OVERRIDE": None,
    "UNAUTHENTICATED_USER": None,
    # Per vessel (boats) and per user (operators), in the cache below (vessels/throttles.py).
    "DEFAULT_THROTTLE_CLASSES": [
        "vessels.throttles.BoatRateThrottle",
        "vessels.throttles.OperatorRateThrottle",
    ],
    "DEFAULT_THROTTLE_RATES": {
        # A boat posting every second and polling every 2 s makes ~100 requests a minute.
        "boat": env_rate("THROTTLE_BOAT_RATE", "600/min"),
        "operator": env_rate("THROTTLE_OPERATOR_RATE", "1200/min"),
    },
}

SPECTACULAR_SETTINGS = {
    "TITLE": "Shoreside API",
    "DESCRIPTION": "Boat API (vessel keys) and operator API (session or token).",
    "VERSION": "1",
    "SERVE_INCLUDE_SCHEMA": False,
    # Request bodies get their own components: what a client must send (non-blank strings,
    # files as binary, no read-only fields) differs from what it gets back.
    "COMPONENT_SPLIT_REQUEST": True,
    # Served from static files: the site must work at sea without internet.
    "SWAGGER_UI_DIST": "SIDECAR",
    "SWAGGER_UI_FAVICON_HREF": "SIDECAR",
    "REDOC_DIST": "SIDECAR",
    # Several models have a `kind`: each choice set gets its own name in the schema.
    "ENUM_NAME_OVERRIDES": {
        "VesselKindEnum": "vessels.models.VesselKind.choices",
        "RuleKindEnum": "alerts.models.RuleKind.choices",
        "ChannelKindEnum": "alerts.models.ChannelKind.choices",
    },
    "POSTPROCESSING_HOOKS": [
        "drf_spectacular.hooks.postprocess_schema_enums",
        "fleet.schema.add_error_responses",
    ],
}

# Operators' personal API tokens (operators app on django-rest-knox): only a SHA-512 digest
# is stored; `sst_` makes a leaked token recognisable. Issued by the admin and `issue_token`.
KNOX_TOKEN_MODEL = "operators.OperatorToken"
REST_KNOX = {"TOKEN_MODEL": KNOX_TOKEN_MODEL, "TOKEN_PREFIX": "sst_", "AUTH_HEADER_PREFIX": "Token"}
# knox's own migrations would still create its (swapped-out) table, unused, with a foreign key
# to auth_user that makes flush's TRUNCATE fail on PostgreSQL.
MIGRATION_MODULES = {"knox": None}

# Map tiles come from a configurable URL; empty means no tile layer at all (at sea): the maps
# still show vessels, tracks and waypoints on a plain background with a scale bar, a lat/lon
# graticule and the coordinates under the cursor. The map pages add the tile layer themselves
# (fleet.context_processors.maps, read per request), so django-leaflet adds none.
MAP_TILES_URL = os.environ.get("MAP_TILES_URL", "https://tile.openstreetmap.org/{z}/{x}/{y}.png")
MAP_TILES_ATTRIBUTION = os.environ.get("MAP_TILES_ATTRIBUTION", "© OpenStreetMap contributors")
# Seconds between the fleet map's polls of /api/v1/fleet/ (a 304 when nothing changed).
FLEET_MAP_POLL_S = env_int("FLEET_MAP_POLL_S", 5)
# The fleet map's trails: each vessel's positions of the last this many minutes, fading with
# age (0 = none; the page offers other lengths), read from /api/v1/fleet/overlays/ every
# FLEET_MAP_TRAIL_REFRESH_S seconds with the running missions; the fleet poll's fixes extend
# them in between.
FLEET_MAP_TRAIL_MINUTES = env_int("FLEET_MAP_TRAIL_MINUTES", 60)
FLEET_MAP_TRAIL_REFRESH_S = env_int("FLEET_MAP_TRAIL_REFRESH_S", 60)
if not 0 <= FLEET_MAP_TRAIL_MINUTES <= 24 * 60:
    raise ValueError(f"FLEET_MAP_TRAIL_MINUTES={FLEET_MAP_TRAIL_MINUTES} is not 0 to 1440 minutes")
if FLEET_MAP_TRAIL_REFRESH_S < 5:
    raise ValueError(f"FLEET_MAP_TRAIL_REFRESH_S={FLEET_MAP_TRAIL_REFRESH_S} is under 5 seconds")
LEAFLET_CONFIG = {
    "TILES": [],
    "DEFAULT_CENTER": (-32.0, 115.75),
    "DEFAULT_ZOOM": 9,
    "RESET_VIEW": False,
}

# Boat API tuning.
FIX_MAX_BATCH = env_int("FIX_MAX_BATCH", 5000)
# A fix more than this far ahead of the server clock is a clock fault, not data.
FIX_MAX_FUTURE_S = env_int("FIX_MAX_FUTURE_S", 300)
# Retention (telemetry.retention): fixes older than FIX_RETENTION_DAYS are thinned to the first
# and last of each FIX_THIN_INTERVAL_S (and every fix an alert points at); 0 = keep every fix.
FIX_RETENTION_DAYS = env_int("FIX_RETENTION_DAYS", 0)
FIX_THIN_INTERVAL_S = env_int("FIX_THIN_INTERVAL_S", 60)
if FIX_RETENTION_DAYS < 0:
    raise ValueError(f"FIX_RETENTION_DAYS={FIX_RETENTION_DAYS} is negative (0 keeps every fix)")
if not 1 <= FIX_THIN_INTERVAL_S <= 86400:
    raise ValueError(f"FIX_THIN_INTERVAL_S={FIX_THIN_INTERVAL_S} is not 1 to 86400 seconds")
# Writing last_used_at on every poll would serialise polls on SQLite's write lock.
KEY_TOUCH_INTERVAL_S = env_int("KEY_TOUCH_INTERVAL_S", 60)
# PostgreSQL: the single-fix post is prepared once per connection (vessels.sql.execute_prepared).
# Off (0) behind a pooler in transaction mode that loses prepared statements (pgBouncer < 1.21).
DB_PREPARED_STATEMENTS = env_bool("DB_PREPARED_STATEMENTS", True)
COMMAND_DEFAULT_TTL_S = env_int("COMMAND_DEFAULT_TTL_S", 24 * 3600)
# Mission checks (vessels.missions): a leg longer than this is refused before sending [50 km].
MISSION_MAX_LEG_M = env_int("MISSION_MAX_LEG_M", 50_000)
# A move_to farther than this from the vessel's last fix is refused; a vessel's own
# move_to_max_m overrides it; 0 = no limit (commands.services.command_validate) [5 km].
MOVE_TO_MAX_M = env_int("MOVE_TO_MAX_M", 5_000)
if MOVE_TO_MAX_M < 0:
    raise ValueError(f"MOVE_TO_MAX_M={MOVE_TO_MAX_M} is negative (0 turns the limit off)")
DATA_UPLOAD_MAX_MEMORY_SIZE = env_int("DATA_UPLOAD_MAX_MEMORY_SIZE", 10 * 1024 * 1024)

# SMS control (sms app): national numbers ("0412 345 678") are read in this ISO 3166 region;
# one number may send SMS_RATE_LIMIT answered messages per SMS_RATE_WINDOW_S (0 = no limit), past
# that they are logged and not answered (one notice says until when).
SMS_DEFAULT_REGION = os.environ.get("SMS_DEFAULT_REGION", "").strip().upper() or "AU"
if SMS_DEFAULT_REGION not in phonenumbers.SUPPORTED_REGIONS:
    raise ValueError(
        f"SMS_DEFAULT_REGION={SMS_DEFAULT_REGION!r} is not a region code (AU, GB, US…)"
    )
SMS_RATE_LIMIT = env_int("SMS_RATE_LIMIT", 10)
SMS_RATE_WINDOW_S = env_int("SMS_RATE_WINDOW_S", 10 * 60)

# Iridium SBD through RockBLOCK (sbd app). In: the delivery webhook POST /api/v1/sbd/rockblock/
# trusts a post only if its JWT verifies against the provider's public key in this PEM file;
# empty: the webhook refuses everything (503). Out: commands as mobile-terminated messages
# through the MT API with this account; no user name: nothing is sent (they stay queued).
SBD_ROCKBLOCK_PUBLIC_KEY_FILE = os.environ.get("SBD_ROCKBLOCK_PUBLIC_KEY_FILE", "").strip()
SBD_ROCKBLOCK_MT_URL = (
    os.environ.get("SBD_ROCKBLOCK_MT_URL", "").strip() or "https://rockblock.rock7.com/rockblock/MT"
)
SBD_ROCKBLOCK_USERNAME = os.environ.get("SBD_ROCKBLOCK_USERNAME", "").strip()
SBD_ROCKBLOCK_PASSWORD = os.environ.get("SBD_ROCKBLOCK_PASSWORD", "")
# Seconds the MT API has to answer; tries of one message before it is given up.
SBD_HTTP_TIMEOUT_S = env_float("SBD_HTTP_TIMEOUT_S", 10.0)
SBD_MT_MAX_ATTEMPTS = env_int("SBD_MT_MAX_ATTEMPTS", 5)
if SBD_HTTP_TIMEOUT_S <= 0 or SBD_MT_MAX_ATTEMPTS < 1:
    raise ValueError("SBD_HTTP_TIMEOUT_S must be positive and SBD_MT_MAX_ATTEMPTS 1 or more")

# Link accounting (links app): the boat API's HTTP counts are kept in each worker's memory and
# written at most this often (seconds; 0: after every response) and at exit. A worker killed
# hard loses at most this many seconds of HTTP counts.
LINK_FLUSH_S = env_float("LINK_FLUSH_S", 10.0)
if LINK_FLUSH_S < 0:
    raise ValueError("LINK_FLUSH_S must be 0 or more")
# Per-vessel routing (manage.py run_links, fleet/routing.py): a pass every LINKS_ROUTE_PERIOD_S
# relays queued commands by SMS or SBD when a vessel's HTTP link is silent or they are urgent.
LINKS_ROUTE_PERIOD_S = env_float("LINKS_ROUTE_PERIOD_S", 15.0)
if LINKS_ROUTE_PERIOD_S <= 0:
    raise ValueError("LINKS_ROUTE_PERIOD_S must be positive")

# Outgoing e-mail (Django's mail settings): alert notifications on e-mail channels.
EMAIL_BACKEND = (
    os.environ.get("EMAIL_BACKEND", "").strip() or "django.core.mail.backends.smtp.EmailBackend"
)
EMAIL_HOST = os.environ.get("EMAIL_HOST", "").strip() or "localhost"
EMAIL_PORT = env_int("EMAIL_PORT", 25)
EMAIL_HOST_USER = os.environ.get("EMAIL_HOST_USER", "")
EMAIL_HOST_PASSWORD = os.environ.get("EMAIL_HOST_PASSWORD", "")
EMAIL_USE_TLS = env_bool("EMAIL_USE_TLS", False)  # STARTTLS, usually on port 587
EMAIL_USE_SSL = env_bool("EMAIL_USE_SSL", False)  # TLS from the start, usually on port 465
if EMAIL_USE_TLS and EMAIL_USE_SSL:
    raise ValueError("EMAIL_USE_TLS and EMAIL_USE_SSL are exclusive: set one (587: TLS, 465: SSL)")
EMAIL_TIMEOUT = env_int("EMAIL_TIMEOUT", 20)
DEFAULT_FROM_EMAIL = (
    os.environ.get("DEFAULT_FROM_EMAIL", "").strip() or "Shoreside <shoreside@localhost>"
)

# Alert notifications (alerts.notify, alerts.services.notifications; docs/alerts.md).
# Seconds a webhook or the HTTP SMS gateway has to answer before the try counts as failed.
ALERTS_HTTP_TIMEOUT_S = env_int("ALERTS_HTTP_TIMEOUT_S", 10)
# SMS channels go out through the shore's own GSM modem (a pyserial URL: /dev/ttyUSB2,
# socket://host:port) or through an HTTP SMS gateway (a JSON POST with a bearer token).
ALERTS_SMS_MODEM_URL = os.environ.get("ALERTS_SMS_MODEM_URL", "").strip()
ALERTS_SMS_GATEWAY_URL = os.environ.get("ALERTS_SMS_GATEWAY_URL", "").strip()
ALERTS_SMS_GATEWAY_TOKEN = os.environ.get("ALERTS_SMS_GATEWAY_TOKEN", "").strip()
if ALERTS_SMS_MODEM_URL and ALERTS_SMS_GATEWAY_URL:
    raise ValueError("set ALERTS_SMS_MODEM_URL or ALERTS_SMS_GATEWAY_URL, not both")
# More than this many notifications for one e-mail or SMS channel and one event due at once
# are sent as one summary (twenty boats going overdue when the uplink drops); 0 = never.
ALERTS_NOTIFY_FLOOD = env_int("ALERTS_NOTIFY_FLOOD", 3)
# Tries before a notification that keeps failing temporarily is given up (backoff between).
ALERTS_NOTIFY_MAX_ATTEMPTS = env_int("ALERTS_NOTIFY_MAX_ATTEMPTS", 8)
if ALERTS_NOTIFY_FLOOD < 0 or ALERTS_NOTIFY_MAX_ATTEMPTS < 1 or ALERTS_HTTP_TIMEOUT_S < 1:
    raise ValueError(
        "ALERTS_NOTIFY_FLOOD must be 0 or more, ALERTS_NOTIFY_MAX_ATTEMPTS and "
        "ALERTS_HTTP_TIMEOUT_S 1 or more"
    )

# The alerts evaluator (manage.py run_alerts, alerts/evaluator.py): a pass every ALERTS_PERIOD_S;
# fixes received up to ALERTS_FIX_OVERLAP_S before the last pass are read again (ingest stamps
# received_at before its transaction commits); an endurance rule without its own empty voltage
# (the rule's minimum) uses ALERTS_BATTERY_EMPTY_V; the loop thins old fixes every
# ALERTS_PRUNE_EVERY_S seconds (0: it never does; run manage.py prune_fixes from cron instead).
ALERTS_PERIOD_S = env_float("ALERTS_PERIOD_S", 3.0)
ALERTS_FIX_OVERLAP_S = env_float("ALERTS_FIX_OVERLAP_S", 30.0)
ALERTS_BATTERY_EMPTY_V = env_float("ALERTS_BATTERY_EMPTY_V", 10.5)
ALERTS_PRUNE_EVERY_S = env_int("ALERTS_PRUNE_EVERY_S", 0)
if ALERTS_PERIOD_S <= 0 or ALERTS_FIX_OVERLAP_S < 0 or ALERTS_PRUNE_EVERY_S < 0:
    raise ValueError(
        "ALERTS_PERIOD_S must be positive; ALERTS_FIX_OVERLAP_S and "
        "ALERTS_PRUNE_EVERY_S must not be negative"
    )

# The cache holds the API throttles' and the failed logins' counters. `locmem` counts in each
# process alone, so under N gunicorn workers a limit is up to N times looser; `file` (in the
# data dir) is shared by the workers of one machine; `database` by several machines (run
# `manage.py createcachetable` once; it writes on every API request: PostgreSQL, not SQLite).
_CACHE_BACKENDS = {
    "locmem": ("django.core.cache.backends.locmem.LocMemCache", "shoreside"),
    "file": ("django.core.cache.backends.filebased.FileBasedCache", str(DATA_DIR / "cache")),
    "database": ("django.core.cache.backends.db.DatabaseCache", "shoreside_cache"),
}
_cache = os.environ.get("CACHE_BACKEND", "").strip().lower() or "locmem"
if _cache not in _CACHE_BACKENDS:
    raise ValueError(f"CACHE_BACKEND={_cache!r} is not one of {', '.join(_CACHE_BACKENDS)}")
_backend, _location = _CACHE_BACKENDS[_cache]
CACHES = {"default": {"BACKEND": _backend, "LOCATION": _location}}
# Failed admin logins per user name and client address before that pair is refused for
# LOGIN_LOCKOUT_S seconds (operators/login.py).
LOGIN_FAILURE_LIMIT = env_int("LOGIN_FAILURE_LIMIT", 5)
LOGIN_LOCKOUT_S = env_int("LOGIN_LOCKOUT_S", 15 * 60)

LOGGING = {
    "version": 1,
    "disable_existing_loggers": False,
    "formatters": {"plain": {"format": "%(asctime)s %(levelname)s %(name)s: %(message)s"}},
    # A legacy boat's `?key=` (and a refused v1 one) must not reach the logs (fleet/logs.py).
    "filters": {"hide_keys": {"()": "fleet.logs.HideKeys"}},
    "handlers": {
        "console": {
            "class": "logging.StreamHandler",
            "formatter": "plain",
            "filters": ["hide_keys"],
        }
    },
    "root": {"handlers": ["console"], "level": os.environ.get("LOG_LEVEL", "INFO")},
    # runserver's request lines (with their query strings) through the same filtered handler.
    "loggers": {"django.server": {"handlers": ["console"], "level": "WARNING", "propagate": False}},
}
