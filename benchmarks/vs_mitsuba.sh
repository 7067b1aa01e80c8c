#!/usr/bin/env bash
# lift-gl pt vs Mitsuba 3 (llvm_ad_rgb) on Lift's cornell-box, 128x128, error against time,
# interleaved in one run so both see the same machine load.
#   MITSUBA_PYTHON=/path/to/python-with-mitsuba  bash benchmarks/vs_mitsuba.sh OUTDIR [ROUNDS]
# Each round: pt as rendered by default, then Mitsuba at 128x128 (box filter), then Mitsuba at
# the film's own 1024x1024 with the scene's triangle filter, box-downsampled to 128x128 (how
# the reference was made; 1-16 spp there are 64-1024 samples per output pixel). All record
# wall and CPU time.
# Mitsuba's llvm variant needs libLLVM >= 16 (Debian libllvm19): DRJIT_LIBLLVM_PATH is set below.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/vs_mitsuba}
rounds=${2:-2}
mkdir -p "$out"
shared=../shared
: "${MITSUBA_PYTHON:?set MITSUBA_PYTHON to a python with mitsuba 3 installed}"
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM-19.so}
.venv/bin/python benchmarks/export_mitsuba.py $shared/scenes_lift/cornell-box/scene.pbrt "$out/mitsuba_scene" --size 128
.venv/bin/python benchmarks/export_mitsuba.py $shared/scenes_lift/cornell-box/scene.pbrt "$out/mitsuba_film" --size 1024 --scene-filter
for round in $(seq 1 "$rounds"); do
  uptime >> "$out/load.txt"
  .venv/bin/python benchmarks/cornell_convergence.py --size 128 --spp 1024 --out "$out/lift_$round.json"
  PYTHONPATH=. "$MITSUBA_PYTHON" benchmarks/mitsuba_convergence.py "$out/mitsuba_scene/scene.xml" \
      $shared/refs/lift/cornell-box.exr --spp 1024 --out "$out/mitsuba_$round.json"
  PYTHONPATH=. "$MITSUBA_PYTHON" benchmarks/mitsuba_convergence.py "$out/mitsuba_film/scene.xml" \
      $shared/refs/lift/cornell-box.exr --spp 16 --downsample 8 --out "$out/mitsuba_film_$round.json"
done
uptime >> "$out/load.txt"
