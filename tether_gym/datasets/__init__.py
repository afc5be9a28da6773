"""Offline datasets: the planners' and the baselines' episodes on the ladder's rungs in Minari's
format (Farama's standard for offline RL), made by `tether dataset create` (`create`: what a
dataset holds, its id, its metadata) and read by `minari.load_dataset` alone; the env that
`recover_environment` rebuilds needs tether_gym installed. Making one needs the optional extra
"datasets" (`pip install "tether-gym[datasets]"`)."""
