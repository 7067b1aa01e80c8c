#!/usr/bin/env bash
# The closing GPU run of issue 10 (docs/gpu.md "Closing run"), in two device calls:
#   PART=1  pt frames and ray kinds on Lift's scenes and the Covered Dragon at 1280x720 and
#           1920x1080, Mitsuba 3 on the cornell-box in the same run, bdpt frames, and a
#           6.4M-triangle dragon;
#   PART=2  bdpt's trace pass, this checkout's against earlier versions of plugins/bdpt
#           compiled with this checkout's shaders, dispatched alternately on the same host.
# Prepare, here (a checkout beside ../shared), the carried folder .devwork/final:
#   tar -cJf .devwork/final/lift_scenes.tar.xz -C ../shared scenes_lift assets/meshes/dragon_100k.ply
#   cp mitsuba_slim.tar.xz .devwork/final/   # Mitsuba 3.9.1 + Dr.Jit 1.5.0 cp312, slimmed (docs/gpu.md)
#   cp -r EXPORTED_CORNELL_1920 .devwork/final/mi_cornell   # benchmarks/export_mitsuba.py
#   for v in NAME=REF ...; do   # each an earlier bdpt: REF's plugins/, this checkout's shaders/
#       d=.devwork/final/bdpt_${v%%=*}; mkdir -p $d; git archive HEAD shaders | tar -x -C $d
#       git archive ${v#*=} plugins | tar -x -C $d; done
# There: carry [".gl", ".whl", ".devwork/final"], set PYTHONPATH as ../shared/GPU.md says, and
#   PART=1 bash benchmarks/gpu_session_run.sh; PART=2 bash benchmarks/gpu_session_run.sh
# (results under $OUT; SZ, SIZES, SKIP_BIG, BDPT_SCENES for a smoke run on llvmpipe).
set -u
SZ=${SZ:-1920x1080}
D=$PWD/.devwork/final; W=/tmp/w; mkdir -p $W/shared $W/mi $OUT
tar -xJf $D/lift_scenes.tar.xz -C $W/shared
mkdir -p $W/gpu && tar -c --exclude=./.devwork --exclude=./.gl --exclude=./.whl . | tar -x -C $W/gpu
cd $W/gpu
(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null || echo "no nvidia-smi") > $OUT/gpu.txt
cat $OUT/gpu.txt
s=$W/shared/scenes_lift
if [ "${PART:-1}" = 1 ]; then
    tar -xJf $D/mitsuba_slim.tar.xz -C $W/mi
    printf '#!/bin/sh\nPYTHONPATH=/tmp/w/mi:$PYTHONPATH exec python3 "$@"\n' > $W/mipy; chmod +x $W/mipy
    # 1. pt and the ray kinds, Mitsuba 3 in the same run, bdpt frames
    SHARED=$W/shared LABEL=final MITSUBA_XML=$D/mi_cornell/scene.xml MITSUBA_PYTHON=$W/mipy \
        SIZES=${SIZES:-1280x720,1920x1080} BDPT=1 timeout ${T_MAIN:-330} bash benchmarks/gpu_device.sh $OUT/final 2>&1 | tail -40
    # 2. a 6.4M-triangle dragon (the Lift paper's has 5.5M)
    [ -n "${SKIP_BIG:-}" ] && exit 0
    timeout 60 python3 benchmarks/subdivided_mesh.py $W/shared/assets/meshes/dragon_100k.ply \
        $W/shared/assets/meshes/dragon_6400k.ply --levels ${LEVELS:-3}
    sed 's/dragon_100k.ply/dragon_6400k.ply/' scenes/covered_dragon.toml > scenes/covered_dragon_6400k.toml
    timeout ${T_BIG:-150} python3 benchmarks/gpu.py measure scenes/covered_dragon_6400k.toml --sizes $SZ \
        --integrators pt --no-rays --label final --out $OUT/dragon_6400k.json 2>&1 | grep -v Warning | tail -8
else
    # bdpt's trace pass: `base` = this checkout; each .devwork/final/bdpt_NAME an earlier plugin
    trees=$(for d in $D/bdpt_*; do [ -d "$d" ] && echo "--tree ${d##*/bdpt_}=$d"; done)
    names=$(for d in $D/bdpt_*; do [ -d "$d" ] && printf ',%s' "${d##*/bdpt_}"; done)
    sed "s#\.\./\.\./shared/assets#$W/shared/assets#" scenes/covered_dragon.toml > $W/covered_dragon.toml
    mkdir -p $OUT/bdpt_ab
    for scene in ${BDPT_SCENES:-cornell-box covered_dragon dining-room classroom}; do
        f=$s/$scene/scene.pbrt; [ $scene = covered_dragon ] && f=$W/covered_dragon.toml
        echo "== $scene $(date -u +%T)"
        PYTHONUNBUFFERED=1 timeout ${T_BDPT:-110} python3 benchmarks/gpu_pt_variants.py $f --integrator bdpt \
            --variants base$names $trees --size $SZ --max-depth 32 --reps ${REPS:-3} \
            --out $OUT/bdpt_ab/$scene.json 2>&1 | grep -v "Warning\|index = self.texture\|_methods._mean" | tail -8
    done
fi
exit 0
