"""`python -m tether_gym.agents.pretrained RUN_DIR NAME --command ...`: see `exporter`."""

import sys

from tether_gym.agents.pretrained.exporter import main

sys.exit(main())
