"""`python -m tether_gym COMMAND ...`: the `tether` dispatcher."""

import sys

from tether_gym.cli import main

sys.exit(main())
