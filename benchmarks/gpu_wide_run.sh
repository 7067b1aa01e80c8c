#!/usr/bin/env bash
# The 4-wide BVH against the binary one on the GPU machine (docs/gpu.md "A 4-wide BVH"), one
# device call: pt frames (per-pass timer queries) and ray kinds (ray-casting shader with the
# trace pass's shared stack) on Lift's three scenes and the Covered Dragon, $LIFT_GL_BVH_WIDTH
# 2 and 4 interleaved case by case (gpu.py measure --bvh-width 2,4).
# Prepare, here (a checkout beside ../shared), the carried folder .devwork/wide: this checkout
#   (git archive HEAD) plus lift_scenes.tar.xz (scenes_lift/ and assets/meshes/dragon_100k.ply,
#   as benchmarks/gpu_session_run.sh describes). There: carry [".gl", ".whl", ".devwork/wide"],
#   set PYTHONPATH as ../shared/GPU.md says, cd .devwork/wide and
#   LAYOUTS=2,4,4q BIG=1 bash benchmarks/gpu_wide_run.sh   (results under $OUT/wide_bvh; SZ=160x90 for a
#   smoke run; BIG=1 adds the 6.4M-triangle dragon)
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
    --bvh-width ${LAYOUTS:-2,4} --split-rounds 2 --ray-stack shared --frames ${FRAMES:-16} --label "" --out $OUT/wide_bvh/pt.json 2>&1 \
    | grep -v "Warning\|index = self.texture" > $OUT/wide_bvh/log.txt
tail -40 $OUT/wide_bvh/log.txt
python3 benchmarks/gpu.py table $(echo ${LAYOUTS:-2,4} | tr , '\n' | sed "s#.*#$OUT/wide_bvh/pt.width-&.json#") \
    --md $OUT/wide_bvh/table.md > /dev/null 2>&1
# BIG=1: a 6.4M-triangle dragon (benchmarks/subdivided_mesh.py), pt frames only, each layout once
[ -z "${BIG:-}" ] && exit 0
timeout 60 python3 benchmarks/subdivided_mesh.py $W/shared/assets/meshes/dragon_100k.ply $W/shared/assets/meshes/dragon_6400k.ply --levels ${BIG_LEVELS:-3}
sed 's/dragon_100k.ply/dragon_6400k.ply/' scenes/covered_dragon.toml > scenes/covered_dragon_6400k.toml
PYTHONUNBUFFERED=1 LIFT_GL_BVH_BUILDER=sah timeout ${BIG_LIMIT:-200} python3 benchmarks/gpu.py measure scenes/covered_dragon_6400k.toml \
    --sizes $SZ --integrators pt --no-rays --bvh-width ${LAYOUTS:-2,4} --split-rounds 1 --frames ${FRAMES:-16} --label "" \
    --out $OUT/wide_bvh/dragon_6400k.json 2>&1 | grep -v "Warning\|index = self.texture" > $OUT/wide_bvh/dragon_6400k_log.txt
tail -12 $OUT/wide_bvh/dragon_6400k_log.txt
exit 0
