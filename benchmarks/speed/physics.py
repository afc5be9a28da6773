"""Speed and accuracy of the bounce models, against scipy's DOP853 reference in the same run.

Prints medians over `--repeat` runs of: the impulse model on a batch of 10^6 set-ups, the hybrid
model on a batch of 10^4 at the paper's experimental rho (about 850), one hybrid bounce through
the `bounce_one` fast path, and the scipy reference per bounce (the peer every ratio is taken
against); then the hybrid model's largest error against the reference on the benchmark's set-ups.

    python -m benchmarks.speed.physics            # the issue's figures
    python -m benchmarks.speed.physics --quick    # a smoke run
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks.common import median_seconds
from tether_gym.physics import bounce, bounce_one, perpendicular_speed, stiffness_from_rho
from tether_gym.physics.reference import reference_bounce

RHO = 850.0  # the paper's experimental system (sec. 3.3)


def setups(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """n random set-ups that bounce: tether angles within 81 degrees of the launch direction's
    normal (so that rho is finite), any offset angle and offset, solid disk, e in [0.5, 1], and
    the stiffness giving rho = 850 for each."""
    rng = np.random.default_rng(seed)
    beta = rng.uniform(0.15, np.pi / 2 - 0.15, n) + rng.integers(0, 2, n) * np.pi / 2
    alpha = rng.uniform(-np.pi, np.pi, n)
    offset = rng.uniform(0.0, 1.0, n)
    v_theta = perpendicular_speed(beta, alpha, offset=offset)
    return dict(
        tether_angle=beta,
        offset_angle=alpha,
        offset=offset,
        restitution=rng.uniform(0.5, 1.0, n),
        stiffness=stiffness_from_rho(RHO, 1.0, 10.0, v_theta),
    )


def one(batch: dict[str, np.ndarray], i: int) -> dict[str, float]:
    """Set-up i of a batch as plain floats."""
    return {name: float(values[i]) for name, values in batch.items()}


def relative_error(setup: dict[str, float]) -> float:
    """Hybrid vs reference, over the pre-bounce kinetic-energy scale (unit speed, no spin,
    kappa = 1/2, R = 1): max(|dv|, sqrt(I/m) |dw|)."""
    ref = reference_bounce(**setup)
    res = bounce_one(**setup, model="hybrid")
    return max(np.linalg.norm(res.velocity - ref.velocity), np.sqrt(0.5) * abs(res.spin - ref.spin))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes: a smoke run")
    parser.add_argument("--repeat", type=int, default=None, help="timed runs (default 7)")
    args = parser.parse_args()
    repeat = args.repeat or (3 if args.quick else 7)
    n_impulse, n_hybrid, n_ref, n_one = (
        (100_000, 1_000, 5, 200) if args.quick else (1_000_000, 10_000, 20, 2_000)
    )

    impulse_batch = setups(n_impulse, seed=1)
    impulse_batch.pop("stiffness")
    hybrid_batch = setups(n_hybrid, seed=2)
    single = one(hybrid_batch, 0)
    references = [one(hybrid_batch, i) for i in range(n_ref)]

    t_impulse = median_seconds(lambda: bounce(**impulse_batch), repeat)
    t_hybrid = median_seconds(lambda: bounce(**hybrid_batch, model="hybrid"), repeat)

    def one_bounces():
        for _ in range(n_one):
            bounce_one(**single, model="hybrid")

    t_one = median_seconds(one_bounces, repeat) / n_one

    def reference_bounces():
        for setup in references:
            reference_bounce(**setup)

    t_ref = median_seconds(reference_bounces, repeat) / n_ref

    n_check = 20 if args.quick else 200
    error = max(relative_error(one(hybrid_batch, i)) for i in range(n_check))

    rows = [
        ("impulse bounce, batch", n_impulse, n_impulse / t_impulse, ">= 20M/s", 20e6),
        ("hybrid bounce, batch, rho 850", n_hybrid, n_hybrid / t_hybrid, ">= 300k/s", 3e5),
        ("hybrid bounce_one (fast path)", 1, 1 / t_one, "<= 50 us", 1 / 50e-6),
        ("scipy DOP853 reference (peer)", 1, 1 / t_ref, "", 0.0),
    ]
    print(f"median of {repeat} runs; ratios are throughput over the scipy reference's\n")
    print(f"{'case':32} {'batch':>9} {'bounces/s':>12} {'us/bounce':>10} {'x ref':>9}  target")
    for name, batch, rate, target, needed in rows:
        mark = ("ok" if rate >= needed else "MISSED") if needed and not args.quick else ""
        print(
            f"{name:32} {batch:9d} {rate:12.4g} {1e6 / rate:10.4g} {rate * t_ref:9.4g}"
            f"  {target} {mark}"
        )
    print(
        f"\nhybrid vs reference on {n_check} of the set-ups (rho {RHO:g}, e in [0.5, 1]): "
        f"max relative error {error:.2e} (target <= 1e-6)"
    )


if __name__ == "__main__":
    main()
