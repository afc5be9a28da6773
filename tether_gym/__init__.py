"""tether_gym: a Gymnasium workbench for the tethered-puck bounce."""

__version__ = "0.1.0"
