#!/usr/bin/env bash
# Re-make the viewer screenshots of docs/viewer.md: scripted `lift-gl view` runs under Xvfb.
#   bash scripts/viewer_screenshots.sh [OUT_DIR]      (default docs/viewer)
# Needs the viewer extra and Xvfb (xvfb-run); the Convergence shot needs the shared folder
# (../shared: Lift's Cornell box and its reference).
set -euo pipefail
out=${1:-docs/viewer}
mkdir -p "$out"
view() { xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/lift-gl view --scale 0.5 "$@"; }
shared=../shared

view scenes/cornell.toml --size 960x540 --spp-per-frame 4 --frames 16 --screenshot "$out/cornell-settings.png"
view scenes/cornell.toml --size 960x540 --aov normal --panels statistics --frames 1 --screenshot "$out/aov-normal.png"
view scenes/cornell.toml --size 960x540 --split debug --set debug.mode=1 --panels statistics --spp-per-frame 4 \
     --frames 16 --screenshot "$out/split-pt-debug.png"
view scenes/cornell.toml --size 960x540 --panels statistics,help --frames 2 --screenshot "$out/help.png"
if [[ -f $shared/refs/lift/cornell-box.exr ]]; then
    view "$shared/scenes_lift/cornell-box/scene.pbrt" --size 960x540 --ref "$shared/refs/lift/cornell-box.exr" \
         --panels statistics --spp-per-frame 4 --frames 40 --screenshot "$out/convergence.png"
fi
