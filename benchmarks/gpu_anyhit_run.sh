#!/usr/bin/env bash
# Shadow-ray (any-hit) child orders of the 4-wide BVH (docs/gpu.md "Shadow rays in the 4-wide
# tree"), one device call: pt's trace pass with each order #defined (gpu_pt_variants.py: base,
# any_nearest, any_leaves, interleaved) and the ray kinds (gpu.py ab on the 4-wide tree: the
# base commit's bvh.glsl, this one's, and each order) on Lift's three scenes and the Covered
# Dragon.
# Prepare, here (a checkout beside ../shared), the carried folder .devwork/anyhit: this
#   checkout (git archive HEAD), lift_scenes.tar.xz (as benchmarks/gpu_session_run.sh says)
#   and base_tree/ (git archive BASE shaders: the code the orders are compared against).
#   There: carry [".gl", ".whl", ".devwork/anyhit"], PYTHONPATH as ../shared/GPU.md says, cd
#   .devwork/anyhit and bash benchmarks/gpu_anyhit_run.sh   (results under $OUT/anyhit; SZ=96x64
#   REPS=1 for a smoke run)
set -u
SZ=${SZ:-1920x1080}
D=$PWD; W=${WORK:-/tmp/w}; R=$OUT/anyhit; mkdir -p $W/shared $R
tar -xJf $D/lift_scenes.tar.xz -C $W/shared
mkdir -p $W/gpu && tar -c --exclude=./lift_scenes.tar.xz --exclude=./.venv . | tar -x -C $W/gpu
cd $W/gpu
(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader || echo "no nvidia-smi") > $R/gpu.txt 2>&1
s=$W/shared/scenes_lift
scenes="$s/cornell-box/scene.pbrt $s/dining-room/scene.pbrt $s/classroom/scene.pbrt scenes/covered_dragon.toml"
# 1. pt's trace pass (the renderer's own 4-wide tree on a GPU), the orders interleaved
PYTHONUNBUFFERED=1 timeout ${T_PT:-170} python3 benchmarks/gpu_pt_variants.py $scenes --size $SZ --max-depth 32 \
    --variants base,any_nearest,any_leaves --reps ${REPS:-5} --out $R/pt_trace.json 2>&1 \
    | grep -v "Warning\|index = self.texture\|_methods._mean" > $R/pt_log.txt
tail -12 $R/pt_log.txt
# 2. ray kinds on the same scenes' 4-wide trees (float boxes, what GPUs get)
b=$D/base_tree
PYTHONUNBUFFERED=1 timeout ${T_AB:-80} python3 benchmarks/gpu.py ab $scenes --sizes $SZ --reps ${AB_REPS:-9} \
    --variant base=$b:4 --variant cur=.:4 --variant nearest=.:4:LIFT_BVH4_ANY_NEAREST \
    --variant leaves=.:4:LIFT_BVH4_ANY_LEAVES_FIRST \
    --variant both=.:4:LIFT_BVH4_ANY_NEAREST,LIFT_BVH4_ANY_LEAVES_FIRST \
    --out $R/ab.json --md $R/ab.md 2>&1 | grep -v "Warning\|index = self.texture" > $R/ab_log.txt
tail -12 $R/ab_log.txt
exit 0
