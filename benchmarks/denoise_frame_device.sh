#!/usr/bin/env bash
# The denoisers' GPU numbers in one device call: each shipped network alone at 1920x1080
# (glsl_denoiser.py, each model warmed up, per dispatch against the cost model), then the
# viewer's frame with each (gpu.py interactive: denoise every frame, temporal reprojection) on
# Lift's three scenes at pt's defaults and at Lift's roulette.
#
#   SHARED=../shared [PYTHON=python3] [SIZES=1920x1080] [FRAMES=50] [REPEAT=3] \
#       bash benchmarks/denoise_frame_device.sh OUTDIR
#
# SHARED holds scenes_lift/. Writes OUTDIR/glsl_denoiser.json and, per realtime_model (rt,
# unet), OUTDIR/interactive_MODEL.json and .md.
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
out=${1:?usage: denoise_frame_device.sh OUTDIR}
mkdir -p "$out"
py=${PYTHON:-python3}
shared=${SHARED:-$here/../shared}
scenes="$shared/scenes_lift/cornell-box/scene.pbrt $shared/scenes_lift/dining-room/scene.pbrt $shared/scenes_lift/classroom/scene.pbrt"
"$py" "$here/benchmarks/glsl_denoiser.py" --models "shipped,$here/assets/denoiser/lift_rt.onnx" --sizes "${SIZES:-1920x1080}" \
    --per-dispatch --no-onnxruntime --out "$out/glsl_denoiser.json"
for model in rt unet; do
    "$py" "$here/benchmarks/gpu.py" interactive $scenes --integrators pt,pt:rr_depth=1:rr_min_survival=0 \
        --sizes "${SIZES:-1920x1080}" --denoisers glsl --option "realtime_model=$model" \
        --frames "${FRAMES:-50}" --repeat "${REPEAT:-3}" \
        --out "$out/interactive_$model.json" --md "$out/interactive_$model.md"
done
