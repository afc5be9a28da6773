#!/usr/bin/env bash
# The GPU figures of docs/jax.md, on a machine with jax's CUDA plugin, each part a command of
# under ten minutes, every figure and log into OUTDIR:
#   bash benchmarks/device.sh OUTDIR              # the XLA kernels' throughput
#   PART=train bash benchmarks/device.sh OUTDIR   # TetherBounce's PPO recipe, 5 seeds
#   PART=navigate-train bash benchmarks/device.sh OUTDIR   # PostsReach's aim recipe, 5 seeds
# throughput: the XLA kernels' steps on the device beside the numba vector envs on the host's
#   CPU (benchmarks/speed/jax_throughput.py, one file per group, rewritten after every row so a
#   group cut short by its time limit keeps its rows): TetherBounce at every batch up to
#   262,144; TetherNavigate's impulse builds (set-up, velocity, aim) from batch 64 to 65,536;
#   its hybrid set-up at batches 64 and 1,024 (one repeat: a batched step waits for its
#   longest contact). numba's vector kernels compile in the background from the start.
# train: `make train`'s recipe, 5 seeds in one compiled JAX PPO run, scored on the SB3 run's
#   test episodes (benchmarks/experiments/jax_train.py).
# navigate-train: `tether-train --backend jax` on PostsReach's aim recipe, 5 seeds (its run
#   folder under OUTDIR/runs).
set -u -o pipefail
out=${1:?usage: bash benchmarks/device.sh OUTDIR}
py=${PYTHON:-python3}
mkdir -p "$out"
export PYTHONUNBUFFERED=1
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
"$py" -c "import jax, numba, numpy; print('jax', jax.__version__, jax.devices(), 'numba', \
numba.__version__, 'numpy', numpy.__version__)" || exit 1
throughput() {  # NAME LIMIT ARGS...: one group of rows, its log and JSON under OUTDIR
    local name=$1 limit=$2
    shift 2
    timeout "$limit" "$py" -m benchmarks.speed.jax_throughput --no-compile --sides scan numba \
        --json "$out/$name.json" "$@" 2>&1 | tee "$out/$name.log"
}
case ${PART:-throughput} in
throughput)
    timeout 400 nice "$py" -m tether_gym.cli compile --part vector >"$out/numba_compile.log" 2>&1 &
    compiling=$!
    throughput bounce "${BOUNCE_LIMIT:-110}" --batches 1 64 1024 16384 65536 262144
    throughput navigate_impulse "${IMPULSE_LIMIT:-140}" --env TetherNavigate \
        --dynamics impulse --batches 64 1024 16384 65536
    throughput navigate_hybrid "${HYBRID_LIMIT:-100}" --env TetherNavigate \
        --dynamics hybrid --controls setup --batches 64 1024 --repeats 1
    kill "$compiling" 2>/dev/null
    ;;
train)
    timeout "${TRAIN_LIMIT:-300}" "$py" -m benchmarks.experiments.jax_train --seeds 5 \
        --chunk 250 --json "$out/jax_train.json" 2>&1 | tee "$out/jax_train.log"
    ;;
navigate-train)
    timeout "${TRAIN_LIMIT:-540}" "$py" -m tether_gym.training.train --backend jax \
        --env TetherNavigate_PostsReach-v3 --seeds 5 --no-progress-bar \
        --runs-dir "$out/runs" 2>&1 | tee "$out/navigate_train.log"
    ;;
*)
    echo "PART must be throughput, train or navigate-train" >&2
    exit 2
    ;;
esac
