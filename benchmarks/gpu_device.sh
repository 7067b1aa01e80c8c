#!/usr/bin/env bash
# The GPU frame-time benchmark in one command, for the GPU machine (or, at small sizes, llvmpipe):
# benchmarks/gpu.py on Lift's cornell-box, dining-room and classroom and the Covered Dragon.
#
#   SHARED=../shared [TREES="base=/path/a layout=/path/b"] [LABEL=new] [ROUNDS=1]
#   [SIZES=1280x720,1920x1080] [INTEGRATORS=pt,pt:rr_depth=1:rr_min_survival=0]
#   [EXTRA="gpu.py measure options"] [MITSUBA_XML=scene.xml]
#   [BDPT=1] [BDPT_EXTRA="..."] bash benchmarks/gpu_device.sh OUTDIR
#
# 1. pt (with its own Russian roulette and with Lift's, from the first bounce: the work per
#    frame of the paper's times, docs/integrators.md "Russian roulette") and the ray kinds for each
#    version of the renderer: those in TREES (other checkouts,
#    label=path) and this checkout (LABEL), ROUNDS times, in reversed order every other round
#    so that no version always runs first;
# 2. with MITSUBA_XML (from benchmarks/export_mitsuba.py), Mitsuba 3 on that scene at the
#    largest size, in the same run (benchmarks/mitsuba_frame_time.py);
# 3. with BDPT=1, bdpt for this checkout only (its frames take a second: few of them);
# 4. the tables of everything measured (table.md).
# SHARED holds scenes_lift/ and assets/meshes/dragon_100k.ply (scenes/covered_dragon.toml
# reads it as ../../shared/...: put this checkout beside it).
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
out=${1:?usage: gpu_device.sh OUTDIR}
mkdir -p "$out"
py=${PYTHON:-python3}
shared=${SHARED:-$here/../shared}
sizes=${SIZES:-1280x720,1920x1080}
scenes="$shared/scenes_lift/cornell-box/scene.pbrt $shared/scenes_lift/dining-room/scene.pbrt
        $shared/scenes_lift/classroom/scene.pbrt $here/scenes/covered_dragon.toml"
versions=(${TREES:-} "${LABEL:-new}=$here")
measure() {  # label tree outfile options...
    local label=$1 tree=$2 file=$3; shift 3
    echo "== $label ($tree) $(date -u +%T)"
    PYTHONUNBUFFERED=1 LIFT_GL_TREE=$tree "$py" "$here/benchmarks/gpu.py" measure $scenes --sizes "$sizes" \
        --label "$label" --out "$file" "$@" 2>&1 | grep -v "SceneWarning\|index = self.texture\|^|\|^$\|^Machine\|^Mrays/s by"
}
for round in $(seq 1 "${ROUNDS:-1}"); do
    order=("${versions[@]}")
    if [ $((round % 2)) = 0 ]; then readarray -t order < <(printf '%s\n' "${versions[@]}" | tac); fi
    for v in "${order[@]}"; do
        measure "${v%%=*}" "${v#*=}" "$out/${v%%=*}_$round.json" --integrators "${INTEGRATORS:-pt,pt:rr_depth=1:rr_min_survival=0}" ${EXTRA:-}
    done
done
if [ -n "${MITSUBA_XML:-}" ]; then
    echo "== mitsuba $(date -u +%T)"
    PYTHONUNBUFFERED=1 "${MITSUBA_PYTHON:-$py}" "$here/benchmarks/mitsuba_frame_time.py" "$MITSUBA_XML" \
        --size "${sizes##*,}" --out "$out/mitsuba.json" ${MITSUBA_ARGS:-} 2>&1 | tail -5
fi
if [ "${BDPT:-0}" = 1 ]; then
    measure "${LABEL:-new}-bdpt" "$here" "$out/bdpt.json" --integrators bdpt --no-rays ${BDPT_EXTRA:---frames 1 --repeat 1}
fi
echo "== tables $(date -u +%T)"
files=()
for v in "${versions[@]}"; do
    for f in "$out/${v%%=*}"_*.json; do [ -f "$f" ] && files+=("$f"); done
done
[ ${#files[@]} -gt 0 ] && "$py" "$here/benchmarks/gpu.py" table "${files[@]}" --md "$out/table.md"
[ -f "$out/bdpt.json" ] && "$py" "$here/benchmarks/gpu.py" table "$out/bdpt.json" --md "$out/table_bdpt.md"
exit 0
