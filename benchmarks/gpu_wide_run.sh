#!/usr/bin/env bash
# The 4-wide BVH against the binary one on the GPU machine (docs/gpu.md "A 4-wide BVH"), one
# device call: pt frames (per-pass timer queries) and ray kinds (ray-casting shader with the
# trace pass's shared stack) on Lift's three scenes and the Covered Dragon, $LIFT_GL_BVH_WIDTH
# 2 and 4 interleaved case by case (gpu.py measure --bvh-width 2,4).
# Prepare, here (a checkout beside ../shared), the carried folder .devwork/wide: this checkout
#   (git archive HEAD) plus lift_scenes.tar.xz (scenes_lift/ and assets/meshes/dragon_100k.ply,
#   as benchmarks/gpu_session_run.sh describes). There: carry [".gl", ".whl", ".devwork/wide"],
#   set PYTHONPATH as ../shared/GPU.md says, cd .devwork/wide and
#   bash benchmarks/gpu_wide_run.sh      (results under $OUT/wide_bvh; SZ=160x90 for a smoke run)
set -u
SZ=${SZ:-1920x1080}
D=$PWD; W=${WORK:-/tmp/w}; mkdir -p $W/shared $OUT/wide_bvh
tar -xJf $D/lift_scenes.tar.xz -C $W/shared
mkdir -p $W/gpu && tar -c --exclude=./lift_scenes.tar.xz --exclude=./.venv . | tar -x -C $W/gpu
cd $W/gpu
(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader || echo "no nvidia-smi") > $OUT/wide_bvh/gpu.txt 2>&1
s=$W/shared/scenes_lift
PYTHONUNBUFFERED=1 timeout ${LIMIT:-270} python3 benchmarks/gpu.py measure $s/cornell-box/scene.pbrt \
    $s/dining-room/scene.pbrt $s/classroom/scene.pbrt scenes/covered_dragon.toml --sizes $SZ --integrators pt \
    --bvh-width 2,4 --split-rounds 2 --ray-stack shared --frames ${FRAMES:-16} --label "" --out $OUT/wide_bvh/pt.json 2>&1 \
    | grep -v "Warning\|index = self.texture" > $OUT/wide_bvh/log.txt
tail -40 $OUT/wide_bvh/log.txt
python3 benchmarks/gpu.py table $OUT/wide_bvh/pt.width-2.json $OUT/wide_bvh/pt.width-4.json --md $OUT/wide_bvh/table.md > /dev/null 2>&1
exit 0
