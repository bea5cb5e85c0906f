"""The admin's date and time formats (settings.FORMAT_MODULE_PATH): every time an operator reads
is UTC with seconds and says so, as vessels.display.fmt_time writes it. Found before Django's
own en_GB and en formats (the locale's language part, "en", covers "en-gb"); what is not set
here (the input formats) stays Django's."""

DATETIME_FORMAT = "Y-m-d H:i:s T"  # 2026-11-25 14:03:27 UTC: T names the zone (always UTC here)
SHORT_DATETIME_FORMAT = DATETIME_FORMAT
TIME_FORMAT = "H:i:s"
DATE_FORMAT = "Y-m-d"
SHORT_DATE_FORMAT = DATE_FORMAT
