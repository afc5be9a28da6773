#!/usr/bin/env bash
# The GPU figures of docs/jax.md in one run, on a machine with jax's CUDA plugin:
#   bash benchmarks/device.sh OUTDIR
# 1. TetherBounce's `make train` recipe, 5 seeds in one compiled JAX PPO run, scored on the SB3
#    run's test episodes (benchmarks/experiments/jax_train.py);
# 2. the JAX kernels' throughput on the device beside the numba vector envs on the host's CPU
#    (benchmarks/speed/jax_throughput.py), TetherBounce and TetherNavigate's set-up and velocity
#    controls, every batch up to 65,536;
# 3. with NAVIGATE_TRAIN=1 only (it does not fit a 10-minute call after 1 and 2: run it as a
#    call of its own, `NAVIGATE_TRAIN=1 SKIP_FIGURES=1 bash benchmarks/device.sh OUTDIR`),
#    PostsReach's aim recipe, 5 seeds in one `tether-train --backend jax` run (its run folder
#    under OUTDIR/runs: the final table beside the planners, as SB3's 5-seed row).
# numba's vector kernels compile in the background during 1 (`tether compile --part vector`),
# awaited before 2, whose numba columns they serve. Each stage has a time limit; every figure and log goes to OUTDIR.
set -u -o pipefail
out=${1:?usage: bash benchmarks/device.sh OUTDIR}
py=${PYTHON:-python3}
mkdir -p "$out"
export PYTHONUNBUFFERED=1
nvidia-smi -L
"$py" -c "import jax, numba, numpy; print('jax', jax.__version__, jax.devices(), 'numba', numba.__version__, 'numpy', numpy.__version__)"
if [ -z "${SKIP_FIGURES:-}" ]; then
timeout 300 "$py" -m tether_gym.cli compile --part vector >"$out/numba_compile.log" 2>&1 &
timeout "${TRAIN_LIMIT:-270}" "$py" -m benchmarks.experiments.jax_train --seeds 5 --chunk 250 \
    --json "$out/jax_train.json" 2>&1 | tee "$out/jax_train.log"
wait
timeout "${BOUNCE_LIMIT:-130}" "$py" -m benchmarks.speed.jax_throughput --no-compile \
    --sides scan numba --json "$out/throughput.json" 2>&1 | tee "$out/throughput.log"
timeout "${NAVIGATE_LIMIT:-170}" "$py" -m benchmarks.speed.jax_throughput --env TetherNavigate \
    --controls setup velocity --no-compile --sides scan numba \
    --json "$out/navigate_throughput.json" 2>&1 | tee "$out/navigate_throughput.log"
fi
if [ -n "${NAVIGATE_TRAIN:-}" ]; then
timeout "${NAVIGATE_TRAIN_LIMIT:-540}" "$py" -m tether_gym.training.train --backend jax \
    --env TetherNavigate_PostsReach-v3 --seeds 5 --no-progress-bar --runs-dir "$out/runs" 2>&1 \
    | tee "$out/navigate_train.log"
fi
