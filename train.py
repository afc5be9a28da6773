"""Entry point: `python train.py ...` from a clone's root (`make train`) is `tether-train ...`."""

import sys

from tether_gym.training import main

if __name__ == "__main__":
    sys.exit(main())
