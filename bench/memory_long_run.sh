#!/bin/bash
# Peak RSS of `uvnav replay --smooth`, `uvnav assess` and read_out_log for a 2 h and a 24 h
# simulated mission (issue 15 item 9; README "Memory does not grow with the run").
# Usage: bench/memory_long_run.sh [WORKDIR]   (about 45 min on one free core; needs ~1 GB disk)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
V=$ROOT/.venv/bin
W=${1:-$(mktemp -d)}
mkdir -p "$W" && cd "$W"
python3 - "$ROOT" <<'PY'
import sys
root = sys.argv[1]
s = open(f"{root}/data/DEMO.scenario.toml").read()
i = s.index("[[leg]]")
head = s[:i].replace('data_dir = "."', f'data_dir = "{root}/data"')
for n, reps in ((2, 1), (24, 12)):  # the demo's 2 h of legs, once and twelve times
    open(f"D{n}.toml", "w").write(head + s[i:] * reps)
    cfg = open(f"{root}/data/DEMO.toml").read().splitlines()
    out = [f'run_file = "D{n}.RUN"' if ln.startswith("run_file") else
           f'data_dir = "{root}/data"' if ln.startswith("data_dir") else ln for ln in cfg]
    open(f"D{n}.cfg.toml", "w").write("\n".join(out) + "\n")
PY
for n in 2 24; do
  "$V/uvnav" simulate "D$n.toml" --out "D$n.RUN" --truth "D$n.truth.csv" --seed 7 --force
  rm -f "D$n.OUT" "D$n.smooth.jsonl"
  /usr/bin/time -f "replay --smooth D$n peak_rss_kb=%M wall_s=%e" \
    "$V/uvnav" replay "D$n.RUN" --config "D$n.cfg.toml" --out "D$n.OUT" --smooth "D$n.smooth.jsonl" >/dev/null
  /usr/bin/time -f "assess D$n peak_rss_kb=%M wall_s=%e" "$V/uvnav" assess "D$n.OUT" "D$n.truth.csv" >/dev/null
  /usr/bin/time -f "read_out_log D$n peak_rss_kb=%M wall_s=%e" "$V/python" -c \
    "from engine.io.outlog import read_out_log; log = read_out_log('D$n.OUT'); print(sum(1 for c in log.cycles))" >/dev/null
done
