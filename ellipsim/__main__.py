"""`python -m ellipsim ...`: the command line, as the `ellipsim` script."""

import sys

from .app.cli import script

sys.exit(script())
