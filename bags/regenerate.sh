#!/usr/bin/env bash
# Regenerate the sample bags byte for byte (see bags/README.md).
#   bash bags/regenerate.sh            # rewrite bags/healthy, bags/wearing, bags/fault
#   bash bags/regenerate.sh OUTDIR     # write them under OUTDIR instead
# PYTHON overrides the interpreter (default: the repository's .venv).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out="${1:-$here}"
python="${PYTHON:-$here/../.venv/bin/python}"
simulate() { "$python" -m gear_phm.cli.main simulate --rate 100 "$@"; }

mkdir -p "$out"
rm -rf "$out/healthy" "$out/wearing" "$out/fault"
# healthy: lever u = 0.05 for 120 s
simulate --out "$out/healthy" --duration 120 --seed 1 \
    --wear constant --friction-initial 0.05
# wearing: u grows exponentially 0.05 -> 0.30 in 300 s (eta_D 0.937 -> 0.700)
simulate --out "$out/wearing" --duration 300 --seed 2 \
    --wear exponential --friction-initial 0.05 --friction-final 0.30
# fault: u = 0.05, steps by +0.15 to 0.20 at t = 60 s (eta_D 0.937 -> 0.778)
simulate --out "$out/fault" --duration 120 --seed 3 \
    --wear step --friction-initial 0.05 --t-fault 60 --fault-step 0.15
