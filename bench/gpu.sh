#!/usr/bin/env bash
# The GPU check of ellipsim on MuJoCo Warp (issue 47), one command on a lent GPU machine.
#
#   here:                 ../shared/tools/gpu-stage        (warp-lang, mujoco, mujoco-warp, the project's wheel)
#   on the GPU machine:   source .gpu/N/unstage.sh && bench/gpu.sh --out "$OUT"
#
# It builds nothing (the project is the staged wheel: python -P keeps this tree's sources off the path) and
# prints the report of ellipsim/app/bench/on_gpu.py: attached and plain Warp against ellipsim's CPU answer,
# then the heap and the pile at 1, 64, 1024 and 4096 worlds, steps per second and the collision stage, graphs
# captured.  About 5 minutes on an H100 (most of it Warp compiling its kernels); within 8.
# Here, as far as the CPU allows:  bench/gpu.sh --device cpu --worlds 1,2 --pairs 4 --launches 2
set -euo pipefail
exec "${PYTHON:-python3}" -P -m ellipsim.app.bench.on_gpu "$@"
