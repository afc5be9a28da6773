"""Entry point: `python -m agents.evaluate ...` from a clone's root is `tether-evaluate ...`."""

from tether_gym.evaluation.cli import main

if __name__ == "__main__":
    main()
