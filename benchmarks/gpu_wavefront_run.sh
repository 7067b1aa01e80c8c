#!/usr/bin/env bash
# Issue 10, deliverable 2: pt's trace pass as the megakernel and as wavefronts
# (lift_gl/passes/wavefront.py), interleaved on one renderer per case (benchmarks/gpu.py
# wavefront), on Lift's three scenes and the Covered Dragon; one device call (docs/gpu.md).
# Prepare a folder of this checkout with the scenes beside it:
#   git archive HEAD | tar -x -C .devwork/NAME
#   tar -cJf .devwork/NAME/lift_scenes.tar.xz -C ../shared scenes_lift assets/meshes/dragon_100k.ply
# There (PYTHONPATH as ../shared/GPU.md says), from that folder:
#   bash benchmarks/gpu_wavefront_run.sh     (results under $OUT; SIZES, VARIANTS, ROUNDS for a smoke run;
#   SCENES: names of scenes_lift/ or .toml paths, the same one twice for a warm-up case)
# The start-kernel prefix run (docs/gpu.md, results/gpu_h100/wavefront/prefix/):
#   SIZES=1920x1080 VARIANTS=mega,wave4,wave8,wave4p3,wave4p4,wave8p3,wave8p4 PROFILE=wave4p4 \
#   SCENES="cornell-box dining-room classroom scenes/covered_dragon.toml cornell-box" LIMIT=225
set -u
W=${WORK:-/tmp/w}; mkdir -p $W/shared $W/gpu $OUT
tar -xJf lift_scenes.tar.xz -C $W/shared
tar -c --exclude=./lift_scenes.tar.xz . | tar -x -C $W/gpu
cd $W/gpu   # beside shared/: scenes/covered_dragon.toml reads ../../shared/assets/...
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $OUT/gpu.txt 2>&1; cat $OUT/gpu.txt
s=$W/shared/scenes_lift
limit=${LIMIT:-150}; variants=${VARIANTS:-mega,wave32,wave8,wave4,wave8-split,wave4-split}; profile=${PROFILE:-}
scenes=
for n in ${SCENES:-cornell-box dining-room classroom scenes/covered_dragon.toml}; do
    case $n in *.toml) scenes="$scenes $n";; *) scenes="$scenes $s/$n/scene.pbrt";; esac
done
for size in ${SIZES:-1920x1080 1280x720}; do   # the later sizes: LIMIT2, VARIANTS2, no profile
    PYTHONUNBUFFERED=1 timeout $limit python3 benchmarks/gpu.py wavefront $scenes --sizes $size \
        --variants $variants --rounds ${ROUNDS:-5} --frames ${FRAMES:-8} --profile "$profile" \
        --out $OUT/wavefront_$size.json --md $OUT/wavefront_$size.md 2>&1 | grep -v "Warning\|index = self.texture\|^|"
    limit=${LIMIT2:-90}; variants=${VARIANTS2:-$variants}; profile=
done
exit 0
