#!/usr/bin/env bash
# bdpt on the GPU machine: this checkout's plugin against another commit's, in one run.
#
# Here (a git checkout), once:   bash benchmarks/bdpt_gpu_ab.sh prepare BASE_REF DEST SHARED
#   DEST/new    this checkout at HEAD (git archive)
#   DEST/base   BASE_REF's plugins/ and shaders/ (what variant `tree` compiles)
#   DEST/shared/scenes_lift/{cornell-box,dining-room,classroom}, copied from SHARED
# There (DEST carried, cwd DEST/new):   bash benchmarks/bdpt_gpu_ab.sh run OUTDIR
#   1. gpu_pt_variants.py --integrator bdpt --variants tree,base,bdpt_unpacked: the plugins compiled on
#      the same host and dispatched alternately over the same G-buffer (trace pass, GL timer
#      queries, median of REPS) at each size in SIZES, path length 32, 1 spp. In its tables
#      `tree` is BASE_REF's bdpt (the old one), `base` this checkout's, and the column
#      "x base" of row `base` is old ms / new ms; `bdpt_unpacked` is this checkout's with
#      the stored vertices' directions as floats (BDPT_PACK_NORMALS 0);
#   2. gpu.py measure for this checkout's bdpt: whole frames (each pass timed), for the table
#      beside the Lift paper's numbers.
set -uo pipefail
case "${1:-}" in
prepare)
    ref=${2:?BASE_REF}; dest=${3:?DEST}; shared=${4:?SHARED}
    here=$(cd "$(dirname "$0")/.." && pwd)
    mkdir -p "$dest/new" "$dest/base" "$dest/shared/scenes_lift"
    git -C "$here" archive HEAD | tar -x -C "$dest/new"
    git -C "$here" archive "$ref" plugins shaders | tar -x -C "$dest/base"
    for s in cornell-box dining-room classroom; do cp -a "$shared/scenes_lift/$s" "$dest/shared/scenes_lift/"; done
    du -sh "$dest"
    ;;
run)
    out=${2:?OUTDIR}; mkdir -p "$out"
    py=${PYTHON:-python3}
    s=../shared/scenes_lift
    scenes="$s/cornell-box/scene.pbrt $s/dining-room/scene.pbrt $s/classroom/scene.pbrt"
    for size in $(echo "${SIZES:-1920x1080,1280x720}" | tr , ' '); do
        echo "== bdpt: tree = the base commit's plugin, base = this checkout's; $size $(date -u +%T)"
        PYTHONUNBUFFERED=1 "$py" benchmarks/gpu_pt_variants.py $scenes --integrator bdpt --variants tree,base,bdpt_unpacked \
            --base-tree ../base --size "$size" --max-depth 32 --reps "${REPS:-5}" --out "$out/bdpt_ab_$size.json" \
            --dump-binaries "$out/binaries_$size" 2>&1 | grep -v "Warning\|index = self.texture" > "$out/bdpt_ab_$size.md"
        cat "$out/bdpt_ab_$size.md"
    done
    echo "== bdpt frames (new) $(date -u +%T)"
    PYTHONUNBUFFERED=1 "$py" benchmarks/gpu.py measure $scenes --integrators bdpt --no-rays --frames 4 --repeat 1 \
        --sizes "${SIZES:-1920x1080,1280x720}" \
        --label new-bdpt --out "$out/bdpt_frames.json" 2>&1 | grep -v "SceneWarning\|index = self.texture" | tail -20
    ;;
*)
    echo "usage: bdpt_gpu_ab.sh prepare BASE_REF DEST SHARED | run OUTDIR" >&2; exit 2 ;;
esac
