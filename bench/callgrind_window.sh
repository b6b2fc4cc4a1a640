#!/bin/bash
# Instructions per demo epoch (callgrind), counted only over 200 epochs after a 20-epoch warm-up
# (callgrind_control switches counting on and off), the .OUT written, one OpenBLAS thread, a
# fixed hash seed: reproducible to about 0.1 % between runs of the same tree, unlike the
# difference of two whole runs. Needs valgrind (not installed by the Makefile).
# Usage: bench/callgrind_window.sh [TREE]   (default: this checkout; uses TREE/.venv or python3)
# HISTORY=3600 WARM=2000 N=5000 bench/callgrind_window.sh: the session's default history (3600
# kept cycles) and a window long enough to hold the cyclic collector's full collections; the
# default (HISTORY=1, WARM=20, N=200) leaves the collector's work out (docs/PERFORMANCE.md).
tree=$(cd "${1:-$(dirname "$0")/..}" && pwd) || exit 1
py=${PYTHON:-$tree/.venv/bin/python}; [ -x "$py" ] || py=python3
history=${HISTORY:-1}; warm=${WARM:-20}; n=${N:-200}
script=$(mktemp --suffix=.py)
trap 'rm -f "$script"' EXIT
cat > "$script" <<PY
import gc, os, subprocess, sys, tempfile
from pathlib import Path
from engine.run.config import load_config
from engine.run.session import Session
cfg = load_config(Path("data/DEMO.toml"))
s = Session(cfg, out_path=Path(tempfile.mkdtemp()) / "B.OUT", force=True, history=$history)
s.run(max_cycles=$warm)
gc.collect()
subprocess.run(["callgrind_control", "-i", "on", str(os.getpid())], capture_output=True)
s.run(max_cycles=$n)
subprocess.run(["callgrind_control", "-i", "off", str(os.getpid())], capture_output=True)
s.close()
PY
cd "$tree" || exit 1
count=$(OPENBLAS_NUM_THREADS=1 PYTHONHASHSEED=0 PYTHONPATH="$tree" valgrind --tool=callgrind \
    --instr-atstart=no --callgrind-out-file=/dev/null "$py" "$script" 2>&1 |
    sed -n 's/.*Collected : //p')
[ -n "$count" ] || { echo "callgrind_window: no count (is valgrind installed?)" >&2; exit 1; }
echo "$tree: $((count / n)) instructions/epoch (history $history, epochs $warm+1..$((warm + n)))"
