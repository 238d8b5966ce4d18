#!/usr/bin/env bash
# The GPU benchmarks of discover in one go, for a machine lent for minutes: the chassis programs'
# kernels per step and pass times (bench_chassis_programs.py), then one four-wheel discover on the
# GPU, cold and warm, against the CPU (bench_gpu_discover.py). Records and logs go to OUTDIR.
# Where the machine's Python lacks jsonschema, run tools/gpu_wheels.sh beforehand and carry .whl:
# its wheels are installed into /tmp/site here.
#   benchmarks/gpu_session.sh OUTDIR [bench_gpu_discover.py options]
set -uo pipefail
out=$(realpath "${1:?usage: benchmarks/gpu_session.sh OUTDIR [options of bench_gpu_discover.py]}")
shift
cd "$(dirname "$0")/.."
if compgen -G ".whl/*.whl" > /dev/null; then
  python3 -m pip install -q --no-index --no-deps --no-compile --target /tmp/site .whl/*.whl || exit 1
  export PYTHONPATH=/tmp/site
fi
export PYTHONPATH="${PYTHONPATH:+$PYTHONPATH:}$PWD/src" PYTHONUNBUFFERED=1
cd benchmarks
python3 bench_chassis_programs.py --json "$out/chassis_programs.json" 2>&1 | tee "$out/chassis_programs.log"
python3 bench_gpu_discover.py --out /tmp/gpu_discover --case fw_step_060 --jobs auto --json "$out/gpu_discover.json" "$@" 2>&1 \
  | tee "$out/gpu_discover.log"
