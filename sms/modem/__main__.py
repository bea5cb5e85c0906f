"""``python -m sms.modem``: see :mod:`sms.modem.cli`."""

from __future__ import annotations

import sys

from .cli import main

sys.exit(main())
