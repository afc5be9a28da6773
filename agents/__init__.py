"""Entry point: the agents live in `tether_gym.agents`; this folder keeps
`python -m agents.evaluate` working from a clone's root.

Imported as `tether_gym.agents`, this folder is the clone taken for the package: Python started
in the folder that holds a clone named `tether_gym` finds the clone before the installed package
(an empty namespace package: none of the package's code runs, no env is registered). The import
fails, saying so.
"""

if __name__ == "tether_gym.agents":
    raise ImportError(
        f"tether_gym here is the clone, not the package ({__file__} is the clone's agents/ "
        "folder): Python started in the folder that holds a clone named tether_gym imports the "
        "clone, empty, and registers no env. Run Python inside the clone or in another folder "
        "(docs/getting-started.md: The clone's folder)."
    )
