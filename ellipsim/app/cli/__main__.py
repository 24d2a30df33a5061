"""`python -m ellipsim.app.cli ...`: the command line, as the `ellipsim` script."""

import sys

from . import script

sys.exit(script())
