#!/usr/bin/env bash
# The watertight ray/triangle test against Möller–Trumbore on the GPU, one device call
# (docs/gpu.md "Watertight triangle test"): ray kinds (gpu.py ab, in the trace pass's layout)
# and pt's trace pass (gpu_pt_variants.py), all versions interleaved in one process.
# Versions: mt (this tree, LIFT_MOLLER_TRUMBORE), wt (this tree: the watertight test, the
# default), wt_fp64 (with the double-precision fallback), main (main's checkout as it is).
# (The two runs of docs/gpu.md measured earlier forms of the test: this script at 9bbe45f
# and, with AB_VARIANTS/PT_VARIANTS naming the row-form variants, at 2dcaec6.)
# Prepare, here: .devwork/watertight = `git archive` of this branch plus lift_scenes.tar.xz
# (.devwork/final's: scenes_lift and assets/meshes/dragon_100k.ply); the device's repo root is
# main's checkout. There: carry [".gl", ".whl", ".devwork/watertight"], set PYTHONPATH as
# ../shared/GPU.md says, cd .devwork/watertight and
#   bash benchmarks/gpu_watertight_run.sh        (results under $OUT)
# A smoke run on llvmpipe: SHARED=../shared MAIN=../main SZ=64x36 REPS=1 OUT=/tmp/o bash ...
set -u
MAIN=${MAIN:-$(cd ../.. && pwd)}
SZ=${SZ:-1920x1080}
REPS=${REPS:-10}
W=/tmp/wt_run; mkdir -p $W $OUT
if [ -z "${SHARED:-}" ]; then
    mkdir -p $W/shared && tar -xJf lift_scenes.tar.xz -C $W/shared
    mkdir -p $W/gpu && tar -c --exclude=./lift_scenes.tar.xz . | tar -x -C $W/gpu
    cd $W/gpu; SHARED=$W/shared
fi
s=$SHARED/scenes_lift
SCENES="$s/cornell-box/scene.pbrt $s/dining-room/scene.pbrt $s/classroom/scene.pbrt scenes/covered_dragon.toml"
(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader || echo no nvidia-smi) > $OUT/gpu.txt 2>&1
cat $OUT/gpu.txt
# 1. ray kinds, versions interleaved dispatch by dispatch; primary hit counts per version
PYTHONUNBUFFERED=1 timeout ${AB_TIMEOUT:-110} python3 benchmarks/gpu.py ab $SCENES --sizes $SZ --reps $REPS \
    --variant mt=.:binary:LIFT_MOLLER_TRUMBORE --variant wt=.:binary ${AB_VARIANTS:---variant wt_fp64=.:binary:LIFT_WATERTIGHT_FP64 --variant main=$MAIN:binary} \
    --out $OUT/rays_ab.json --md $OUT/rays_ab.md 2>&1 | grep -v "Warning\|index = self" | tail -14
# 2. pt's trace pass (1 spp, path length 32): this tree (wt), mt, wt_fp64, main's pt (tree)
PYTHONUNBUFFERED=1 timeout ${PT_TIMEOUT:-160} python3 benchmarks/gpu_pt_variants.py $SCENES --size $SZ --reps $((REPS / 2 + 2)) \
    --variants ${PT_VARIANTS:-base,mt,wt_fp64,tree} --base-tree $MAIN --out $OUT/pt_variants.json 2>&1 \
    | grep -v "Warning\|index = self" > $OUT/pt_variants.md
tail -16 $OUT/pt_variants.md
exit 0
