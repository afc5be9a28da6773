"""`python -m tether_gym.agents.pretrained RUN_DIR NAME --command ...`: see the package."""

import sys

from tether_gym.agents.pretrained import main

sys.exit(main())
