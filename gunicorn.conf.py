"""gunicorn's settings for Shoreside, read from the current directory (run it from the repo).

Keys in URLs (the legacy `?key=`) are masked in gunicorn's access and error logs.
"""

logger_class = "fleet.gunicorn_logging.Logger"
