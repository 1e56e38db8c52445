#!/usr/bin/env bash
# Regenerate the sample bags byte for byte (see bags/README.md).
#   bash bags/regenerate.sh            # rewrite bags/healthy, bags/wearing, bags/fault, bags/fleet
#   bash bags/regenerate.sh OUTDIR     # write them under OUTDIR instead
# PYTHON overrides the interpreter (default: the repository's .venv).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out="${1:-$here}"
python="${PYTHON:-$here/../.venv/bin/python}"
simulate() { "$python" -m gear_phm.cli.main simulate --rate 100 "$@"; }

mkdir -p "$out"
rm -rf "$out/healthy" "$out/wearing" "$out/fault" "$out/fleet"
# healthy: lever u = 0.05 for 120 s
simulate --out "$out/healthy" --duration 120 --seed 1 \
    --wear constant --friction-initial 0.05
# wearing: u grows exponentially 0.05 -> 0.30 in 300 s (eta_D 0.937 -> 0.700)
simulate --out "$out/wearing" --duration 300 --seed 2 \
    --wear exponential --friction-initial 0.05 --friction-final 0.30
# fault: u = 0.05, steps by +0.15 to 0.20 at t = 60 s (eta_D 0.937 -> 0.778)
simulate --out "$out/fault" --duration 120 --seed 3 \
    --wear step --friction-initial 0.05 --t-fault 60 --fault-step 0.15
# fleet: 3 units x 5 recordings of 20 s, a week of idle time between recordings; linear wear
# 0.05 -> 0.26 over the 100 s of operation; unit start and rate scattered by 20 % (log-normal)
simulate --out "$out/fleet" --fleet 3 --recordings 5 --duration 20 --seed 4 --truth-every 10 \
    --wear linear --friction-initial 0.05 --friction-final 0.26
