"""gunicorn's logger with vessel keys masked (gunicorn.conf.py names it as `logger_class`).

Every access-log atom is masked, so a custom `access_log_format` (`%(r)s`, `%(q)s`,
`%({raw_uri}e)s`, …) cannot bring a `?key=` back; the error log ("Error handling request
/spab/data.cgi?key=…") gets the same filter as Django's loggers.
"""

from __future__ import annotations

from typing import Any

from gunicorn import glogging

from fleet.logs import HideKeys, hide_keys, hide_query


class Logger(glogging.Logger):
    def setup(self, cfg: Any) -> None:
        super().setup(cfg)
        for log in (self.error_log, self.access_log):
            if not any(isinstance(f, HideKeys) for f in log.filters):
                log.addFilter(HideKeys())

    def atoms(self, resp: Any, req: Any, environ: Any, request_time: Any) -> dict[str, Any]:
        atoms = super().atoms(resp, req, environ, request_time)
        for name, value in atoms.items():
            if isinstance(value, str):
                atoms[name] = hide_keys(value)
        for name in ("q", "{query_string}e"):
            if isinstance(atoms.get(name), str):
                atoms[name] = hide_query(atoms[name])
        return atoms
