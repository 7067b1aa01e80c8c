#!/usr/bin/env bash
# The issue-10 benchmark in one command, for the GPU machine (or, at small sizes, llvmpipe):
# benchmarks/gpu.py on Lift's cornell-box, dining-room and classroom and the Covered Dragon,
# pt and bdpt; with BASE set, the renderer in BASE (another checkout) and this one alternately,
# ROUNDS times each (LABEL names this checkout's runs: new); with MITSUBA_XML set, Mitsuba 3 on that scene in the same run.
#
#   SHARED=../shared [BASE=/path/to/baseline/checkout] [ROUNDS=1] [SIZES=1280x720,1920x1080]
#   [MITSUBA_XML=scene.xml] bash benchmarks/gpu_device.sh OUTDIR
#
# SHARED holds scenes_lift/ and assets/meshes/dragon_100k.ply (scenes/covered_dragon.toml
# reads it as ../../shared/...: put this checkout beside it, or give SHARED accordingly).
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
out=${1:?usage: gpu_device.sh OUTDIR}
mkdir -p "$out"
shared=${SHARED:-$here/../shared}
rounds=${ROUNDS:-1}
sizes=${SIZES:-1280x720,1920x1080}
extra=${EXTRA:-}
scenes="$shared/scenes_lift/cornell-box/scene.pbrt $shared/scenes_lift/dining-room/scene.pbrt
        $shared/scenes_lift/classroom/scene.pbrt $here/scenes/covered_dragon.toml"
files=()
run() {  # label tree round
    PYTHONUNBUFFERED=1 LIFT_GL_TREE=$2 "${PYTHON:-python3}" "$here/benchmarks/gpu.py" measure $scenes --sizes "$sizes" \
        --label "$1" --out "$out/$1_$3.json" $extra 2>&1 | grep -v "SceneWarning\|index = self.texture"
    files+=("$out/$1_$3.json")
}
for round in $(seq 1 "$rounds"); do
    # alternate which version goes first, so neither always sees a cold or warm machine
    if [ -n "${BASE:-}" ] && [ $((round % 2)) = 1 ]; then run base "$BASE" "$round"; fi
    run "${LABEL:-new}" "$here" "$round"
    if [ -n "${BASE:-}" ] && [ $((round % 2)) = 0 ]; then run base "$BASE" "$round"; fi
done
if [ -n "${MITSUBA_XML:-}" ]; then
    PYTHONUNBUFFERED=1 "${MITSUBA_PYTHON:-python3}" "$here/benchmarks/mitsuba_frame_time.py" "$MITSUBA_XML" \
        --size "${sizes##*,}" --out "$out/mitsuba.json" ${MITSUBA_ARGS:-} 2>&1 | tail -20
fi
existing=()
for f in "${files[@]}"; do [ -f "$f" ] && existing+=("$f"); done
# base first, so the ratios are new / base
readarray -t existing < <(printf '%s\n' "${existing[@]}" | sort)
[ ${#existing[@]} -gt 0 ] && "${PYTHON:-python3}" "$here/benchmarks/gpu.py" table "${existing[@]}" --md "$out/table.md"
