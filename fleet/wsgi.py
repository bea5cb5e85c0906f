import os

from django.core.wsgi import get_wsgi_application

from fleet.chunked import ChunkedBodyMiddleware

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "fleet.settings")
# Chunked request bodies are read (or answered 411) before Django sees them: fleet/chunked.py.
application = ChunkedBodyMiddleware(get_wsgi_application())
