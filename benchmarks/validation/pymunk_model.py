"""The pymunk model's cost and step error, beside the hybrid model's fast path in the same run.

Speed: one bounce through `bounce_one` at the default settings (45 degree tether, alpha = 0,
disk, the paper's stiffness rho = 850), median over repeats, for model="pymunk" (target: at
most 5 ms) and model="hybrid", and their ratio.
Error: the worst disagreement with the hybrid model over the paper's sweeps (e = 1) for a few
steps per half period, which is how `pymunk_world.EULER_STEPS_PER_HALF_PERIOD` was chosen.

    python -m benchmarks.validation.pymunk_model [--quick]

(Not benchmarks/pymunk.py: run as a script, that name would shadow the pymunk package.)
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from tether_gym.physics import bounce, bounce_one, perpendicular_speed, stiffness_from_rho
from tether_gym.physics.pymunk_world import EULER_STEPS_PER_HALF_PERIOD, TetherWorld

STIFFNESS = float(
    stiffness_from_rho(850.0, 1.0, 10.0, perpendicular_speed(math.pi / 4, 0.0, offset=0))
)


def seconds_per_bounce(model: str, count: int) -> float:
    start = time.perf_counter()
    for _ in range(count):
        bounce_one(math.pi / 4, 0.0, model=model, stiffness=STIFFNESS)
    return (time.perf_counter() - start) / count


def worst_errors(points: int) -> tuple[float, float, float, float]:
    """Max |difference| from the hybrid model over the paper's sweeps, disk and ring, e = 1:
    deflection (degrees, where the puck keeps 5% of its speed), speed ratio, spin, energy."""
    angles = np.linspace(0.0, np.pi, points)
    sweeps = (
        dict(tether_angle=angles[:-1], offset_angle=0.0, offset=0.0),
        dict(tether_angle=np.pi / 4, offset_angle=angles),
        dict(tether_angle=np.pi / 2, offset_angle=angles),
    )
    worst = np.zeros(4)
    for kappa in (0.5, 1.0):
        for sweep in sweeps:
            ours = bounce(**sweep, inertia_ratio=kappa, model="pymunk", stiffness=STIFFNESS)
            hybrid = bounce(**sweep, inertia_ratio=kappa, model="hybrid", stiffness=STIFFNESS)
            moving = hybrid.speed_ratio > 0.05
            turn = np.angle(np.exp(1j * (ours.deflection - hybrid.deflection)))[moving]
            energy = np.sum(ours.velocity**2, axis=-1) + kappa * ours.spin**2
            errors = (
                np.degrees(np.abs(turn)).max(),
                np.abs(ours.speed_ratio - hybrid.speed_ratio).max(),
                np.abs(ours.spin - hybrid.spin).max(),
                np.abs(energy - 1.0).max(),
            )
            worst = np.maximum(worst, errors)
    return tuple(worst)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a short smoke run")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    repeats = 2 if args.quick else args.repeats
    count = 20 if args.quick else 200

    for model in ("pymunk", "hybrid"):
        bounce_one(math.pi / 4, 0.0, model=model, stiffness=STIFFNESS)  # compile, import
    pymunk_s = statistics.median(seconds_per_bounce("pymunk", count) for _ in range(repeats))
    hybrid_s = statistics.median(seconds_per_bounce("hybrid", count * 10) for _ in range(repeats))
    print(f"one bounce at the default settings (k = {STIFFNESS:.1f} N/m), median of {repeats}:")
    print(f"  pymunk  {pymunk_s * 1e3:8.3f} ms   (target <= 5 ms)")
    print(f"  hybrid  {hybrid_s * 1e3:8.3f} ms")
    print(f"  pymunk / hybrid = {pymunk_s / hybrid_s:.0f}x")

    print("\nworst disagreement with the hybrid model over the paper's sweeps, e = 1:")
    print("  steps/half period   deflection (deg)   speed ratio   spin (rad/s)   energy")
    defaults = TetherWorld.__init__.__kwdefaults__
    for steps in (16, 32, 64, 128):
        defaults["taut_steps"] = steps
        errors = worst_errors(7 if args.quick else 25)
        mark = "  <- default" if steps == EULER_STEPS_PER_HALF_PERIOD else ""
        print("  {:>17d}   {:16.4f}   {:11.1e}   {:12.1e}   {:6.1e}".format(steps, *errors) + mark)
    defaults["taut_steps"] = EULER_STEPS_PER_HALF_PERIOD


if __name__ == "__main__":
    main()
