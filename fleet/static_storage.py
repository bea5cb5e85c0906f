"""Static files under names carrying their content's hash (`mapkit.0123456789ab.js`), which
WhiteNoise serves with a year's cache: a map page's scripts, styles and coastline cells are
fetched once per browser, not on every visit (issue 18 §1).

collectstatic writes the names (and the gzip copies). Where it has not run (the tests, a
quick runserver serving from the apps' folders) a page gets the plain names, which WhiteNoise's
finders serve, instead of Django's "Missing staticfiles manifest entry" error.
"""

from __future__ import annotations

from whitenoise.storage import CompressedManifestStaticFilesStorage


class HashedStaticFiles(CompressedManifestStaticFilesStorage):
    manifest_strict = False

    def stored_name(self, name: str) -> str:
        try:
            return super().stored_name(name)
        except ValueError:  # not collected: the file is only in its app's static folder
            return name
