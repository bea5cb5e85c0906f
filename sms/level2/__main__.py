"""``python -m sms.level2``: see :mod:`sms.level2.cli`."""

from __future__ import annotations

import sys

from .cli import main

sys.exit(main())
