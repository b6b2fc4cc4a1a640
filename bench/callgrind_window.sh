#!/bin/bash
# Instructions per demo epoch (callgrind), counted only over 200 epochs after a 20-epoch warm-up
# (callgrind_control switches counting on and off), the .OUT written, one OpenBLAS thread, a
# fixed hash seed: reproducible to about 0.1 % between runs of the same tree, unlike the
# difference of two whole runs. Needs valgrind (not installed by the Makefile).
# Usage: bench/callgrind_window.sh [TREE]   (default: this checkout; uses TREE/.venv or python3)
tree=$(cd "${1:-$(dirname "$0")/..}" && pwd) || exit 1
py=${PYTHON:-$tree/.venv/bin/python}; [ -x "$py" ] || py=python3
script=$(mktemp --suffix=.py)
trap 'rm -f "$script"' EXIT
cat > "$script" <<'PY'
import gc, os, subprocess, sys, tempfile
from pathlib import Path
from engine.run.config import load_config
from engine.run.session import Session
cfg = load_config(Path("data/DEMO.toml"))
s = Session(cfg, out_path=Path(tempfile.mkdtemp()) / "B.OUT", force=True, history=1)
s.run(max_cycles=20)
gc.collect()
subprocess.run(["callgrind_control", "-i", "on", str(os.getpid())], capture_output=True)
s.run(max_cycles=200)
subprocess.run(["callgrind_control", "-i", "off", str(os.getpid())], capture_output=True)
s.close()
PY
cd "$tree" || exit 1
n=$(OPENBLAS_NUM_THREADS=1 PYTHONHASHSEED=0 PYTHONPATH="$tree" valgrind --tool=callgrind \
    --instr-atstart=no --callgrind-out-file=/dev/null "$py" "$script" 2>&1 |
    sed -n 's/.*Collected : //p')
[ -n "$n" ] || { echo "callgrind_window: no count (is valgrind installed?)" >&2; exit 1; }
echo "$tree: $((n / 200)) instructions/epoch"
