"""``python -m rtsim``."""

import sys

from rtsim.cli import main

sys.exit(main())
