#!/usr/bin/env bash
# The closing GPU run of issue 10 (docs/gpu.md "Closing run"), one device call:
#   pt frames and ray kinds on Lift's scenes and the Covered Dragon, Mitsuba 3 on the
#   cornell-box in the same run, bdpt frames, bdpt before/after its rewrite, BVH splits off/auto,
#   and a 6.4M-triangle dragon.
# Prepare, here (a checkout beside ../shared), the carried folder .devwork/final:
#   tar -cJf .devwork/final/lift_scenes.tar.xz -C ../shared scenes_lift assets/meshes/dragon_100k.ply
#   cp mitsuba_slim.tar.xz .devwork/final/   # Mitsuba 3.9.1 + Dr.Jit 1.5.0 cp312, slimmed (docs/gpu.md)
#   cp -r EXPORTED_CORNELL_1920 .devwork/final/mi_cornell   # benchmarks/export_mitsuba.py
#   git archive 3c8f6cb plugins shaders | tar -x -C .devwork/final/bdpt_base
# There: carry [".gl", ".whl", ".devwork/final"], set PYTHONPATH as ../shared/GPU.md says, and
#   bash benchmarks/gpu_session_run.sh      (results under $OUT; SZ, SIZES, SKIP_BIG for a smoke run)
set -u
SZ=${SZ:-1920x1080}
D=$PWD/.devwork/final; W=/tmp/w; mkdir -p $W/shared $W/mi $OUT/final $OUT/splits $OUT/bdpt_ab
tar -xJf $D/lift_scenes.tar.xz -C $W/shared
tar -xJf $D/mitsuba_slim.tar.xz -C $W/mi
printf '#!/bin/sh\nPYTHONPATH=/tmp/w/mi:$PYTHONPATH exec python3 "$@"\n' > $W/mipy; chmod +x $W/mipy
mkdir -p $W/gpu && tar -c --exclude=./.devwork --exclude=./.gl --exclude=./.whl . | tar -x -C $W/gpu
cp -r $D/bdpt_base $W/base
cd $W/gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $OUT/gpu.txt 2>&1; cat $OUT/gpu.txt
# 1. pt and the ray kinds (final main), Mitsuba 3 in the same run, bdpt frames
SHARED=$W/shared LABEL=final MITSUBA_XML=$D/mi_cornell/scene.xml MITSUBA_PYTHON=$W/mipy \
    SIZES=${SIZES:-1280x720,1920x1080} BDPT=1 timeout 290 bash benchmarks/gpu_device.sh $OUT/final 2>&1 | tail -30
# 2. bdpt: 3c8f6cb's (before this session's rewrite) vs the final one, same host, alternating
s=$W/shared/scenes_lift
PYTHONUNBUFFERED=1 timeout 110 python3 benchmarks/gpu_pt_variants.py $s/cornell-box/scene.pbrt $s/dining-room/scene.pbrt \
    $s/classroom/scene.pbrt --integrator bdpt --variants tree,base,bdpt_unpacked --base-tree ../base --size $SZ \
    --max-depth 32 --reps 3 --out $OUT/bdpt_ab/bdpt_ab_$SZ.json 2>&1 | grep -v "Warning\|index = self.texture" > $OUT/bdpt_ab/bdpt_ab_$SZ.md
cat $OUT/bdpt_ab/bdpt_ab_$SZ.md | tail -12
# 3. BVH spatial splits off vs auto
timeout 80 python3 benchmarks/gpu.py measure $s/dining-room/scene.pbrt $s/classroom/scene.pbrt \
    --sizes $SZ --integrators pt --bvh-splits off,auto --out $OUT/splits/pt.json 2>&1 | grep -v Warning | tail -12
# 4. a 6.4M-triangle dragon (the Lift paper's has 5.5M)
[ -n "${SKIP_BIG:-}" ] && exit 0
timeout 60 python3 benchmarks/subdivided_mesh.py $W/shared/assets/meshes/dragon_100k.ply $W/shared/assets/meshes/dragon_6400k.ply --levels 3
sed 's/dragon_100k.ply/dragon_6400k.ply/' scenes/covered_dragon.toml > scenes/covered_dragon_6400k.toml
LIFT_GL_BVH_BUILDER=sah timeout 400 python3 benchmarks/gpu.py measure scenes/covered_dragon_6400k.toml --sizes $SZ --integrators pt \
    --no-rays --label final --out $OUT/dragon_6400k.json 2>&1 | grep -v Warning | tail -8
exit 0
