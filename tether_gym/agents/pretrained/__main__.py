"""`python -m tether_gym.agents.pretrained RUN_DIR NAME --command ...`: see
`tether_gym.evaluation.export`, the exporter, which plays the agents this catalog loads."""

import sys

from tether_gym.evaluation.export import main

sys.exit(main())
