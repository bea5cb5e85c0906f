import sys

from edge_client.sbd.cli import main

sys.exit(main())
