"""`python -m sim.cli`: the `sortsim` command line."""

import sys

from sim.cli.main import main

sys.exit(main())
