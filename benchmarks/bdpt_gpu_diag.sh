#!/usr/bin/env bash
# bdpt on the GPU machine (issue 10): where its trace pass spends its time, and this checkout's
# bdpt against another commit's, in one device call (docs/bdpt.md "On the GPU").
#
# Here (a git checkout), once:   bash benchmarks/bdpt_gpu_diag.sh prepare BASE_REF DEST SCENES_TAR [NAME=REF...]
#   DEST/new    this checkout at HEAD (git archive)
#   DEST/base   BASE_REF's plugins/ and shaders/ (what variant `tree` compiles)
#   DEST/t_NAME each REF's plugins/ and shaders/ (variant NAME: gpu_pt_variants.py --tree)
#   DEST/lift_scenes.tar.xz   scenes_lift/{cornell-box,dining-room,classroom} (+ the dragon's mesh)
# There (DEST carried, cwd DEST/new):   bash benchmarks/bdpt_gpu_diag.sh diag|ab OUTDIR
#   diag: gpu_pt_variants.py --integrator bdpt on Lift's three scenes: `tree` (BASE_REF's bdpt),
#         `base` (this checkout's) and, on the cornell-box, the diagnostic variants (no light
#         tracing, no s >= 2 joins, one subpath only, plain splats, no shadow rays, shorter paths,
#         per-pixel counts); the program binaries (NVIDIA assembly: local memory) in binaries.tgz.
#   ab:   BASE_REF's bdpt against this checkout's only, dispatched alternately, on the three scenes
#         and scenes/covered_dragon.toml at each size of SIZES.
# Each scene runs under its own time limit (T_<scene> seconds), so one slow compile cannot take
# the others' results; SIZE, REPS and the limits can be lowered for a smoke run on llvmpipe.
set -uo pipefail
mode=${1:-}
case "$mode" in
prepare)
    ref=${2:?BASE_REF}; dest=${3:?DEST}; scenes=${4:?SCENES_TAR}
    here=$(cd "$(dirname "$0")/.." && pwd)
    rm -rf "$dest/new" "$dest/base"; mkdir -p "$dest/new" "$dest/base"
    git -C "$here" archive HEAD | tar -x -C "$dest/new"
    git -C "$here" archive "$ref" plugins shaders | tar -x -C "$dest/base"
    cp "$scenes" "$dest/lift_scenes.tar.xz"
    for t in "${@:5}"; do
        rm -rf "$dest/t_${t%%=*}"; mkdir -p "$dest/t_${t%%=*}"
        git -C "$here" archive "${t#*=}" plugins shaders | tar -x -C "$dest/t_${t%%=*}"
    done
    du -sh "$dest"
    ;;
diag|ab)
    out=${2:?OUTDIR}; mkdir -p "$out"
    py=${PYTHON:-python3}
    w=${WORK:-/tmp/bdpt_gpu}; mkdir -p "$w"
    [ -d "$w/scenes_lift" ] || tar -xJf ../lift_scenes.tar.xz -C "$w"
    s=$w/scenes_lift
    sed "s#\.\./\.\./shared/assets#$w/assets#" scenes/covered_dragon.toml > "$w/covered_dragon.toml"  # its mesh
    (nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null || echo "no nvidia-smi") > "$out/gpu.txt"
    trees=$(for d in ../t_*; do [ -d "$d" ] && echo "--tree ${d#../t_}=$d"; done)  # variants named after them
    run() {  # run LIMIT_S NAME SCENE VARIANTS [SIZE]
        local size=${5:-${SIZE:-1920x1080}}
        echo "== $2 $size $(date -u +%T)" | tee -a "$out/log.md"
        PYTHONUNBUFFERED=1 timeout "$1" "$py" benchmarks/gpu_pt_variants.py "$3" --integrator bdpt --variants "$4" \
            --base-tree ../base $trees --size "$size" --max-depth 32 --reps "${REPS:-3}" --out "$out/$2_$size.json" \
            --dump-binaries "$w/binaries" 2>&1 | grep -v "Warning\|index = self.texture\|_methods._mean" | tee -a "$out/log.md"
    }
    if [ "$mode" = diag ]; then
        run "${T_CORNELL:-110}" cornell-box "$s/cornell-box/scene.pbrt" \
            tree,base,bdpt_no_lt,bdpt_no_connect,bdpt_light_only,bdpt_camera_only,bdpt_splat_plain,rr1,noshadow,depth4,bdpt_count_paths
        run "${T_CLASSROOM:-95}" classroom "$s/classroom/scene.pbrt" tree,base,bdpt_count_paths
        run "${T_DINING:-70}" dining-room "$s/dining-room/scene.pbrt" tree,base
    else  # ab: VARIANTS_<SCENE> (default tree,base) for each scene, the cheap compiles first
        for size in $(echo "${SIZES:-1920x1080}" | tr , ' '); do
            run "${T_CORNELL:-40}" cornell-box "$s/cornell-box/scene.pbrt" "${VARIANTS_CORNELL:-tree,base}" "$size"
            run "${T_DRAGON:-40}" covered_dragon "$w/covered_dragon.toml" "${VARIANTS_DRAGON:-tree,base}" "$size"
            run "${T_DINING:-80}" dining-room "$s/dining-room/scene.pbrt" "${VARIANTS_DINING:-tree,base}" "$size"
            run "${T_CLASSROOM:-80}" classroom "$s/classroom/scene.pbrt" "${VARIANTS_CLASSROOM:-tree,base}" "$size"
        done
    fi
    [ -d "$w/binaries" ] && tar -czf "$out/binaries.tgz" -C "$w" binaries
    ls -la "$out"
    ;;
*)
    echo "usage: bdpt_gpu_diag.sh prepare BASE_REF DEST SCENES_TAR | diag OUTDIR | ab OUTDIR" >&2; exit 2 ;;
esac
