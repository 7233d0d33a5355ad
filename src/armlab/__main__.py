"""``python -m armlab``: the ``armlab`` command line."""

import sys

from armlab.cli import main

sys.exit(main())
