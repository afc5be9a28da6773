"""`python -m tether_gym.training.sweep`: the `tether-sweep` command."""

import sys

from tether_gym.training.sweep.cli import main

sys.exit(main())
