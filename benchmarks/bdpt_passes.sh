#!/usr/bin/env bash
# bdpt's frame time, pass by pass, before and after a change: benchmarks/gpu.py measure on Lift's
# cornell-box, dining-room and classroom at the Lift paper's setting (1920x1080, 1 spp, path
# length 32), for every checkout in TREES and this one, alternately, then one table.
#
#   SHARED=.devout/shared TREES="base=/path/to/checkout" [LABEL=new] [ROUNDS=2] [SIZES=1920x1080]
#   [MAX_DEPTH=32] [PARAMS=":mis_power=1"] [EXTRA="--frames 8 --repeat 2"] [SCENES="dining-room classroom"]
#   bash benchmarks/bdpt_passes.sh OUTDIR
#
# Writes OUTDIR/LABEL_ROUND.json (gpu.py's records: frame_ms, pass_ms_query per pass, rays a
# path, Mrays/s) and OUTDIR/table.md. A checkout whose bdpt has a [prepass] (its light pass)
# shows it as the `prepass` pass beside `trace` (the camera pass); a one-pass bdpt has `trace` only.
# PARAMS is appended to "bdpt" in this checkout's runs only (e.g. ":mis_power=1", or a new
# parameter an older bdpt lacks); with it, this checkout is also measured without it.
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
out=${1:?usage: bdpt_passes.sh OUTDIR}
mkdir -p "$out"
py=${PYTHON:-python3}
shared=${SHARED:-$here/../shared}
scenes=""
for name in ${SCENES:-cornell-box dining-room classroom}; do scenes="$scenes $shared/scenes_lift/$name/scene.pbrt"; done
versions=(${TREES:-} "${LABEL:-new}=$here")
for round in $(seq 1 "${ROUNDS:-2}"); do
    order=("${versions[@]}")
    if [ $((round % 2)) = 0 ]; then readarray -t order < <(printf '%s\n' "${versions[@]}" | tac); fi
    for v in "${order[@]}"; do
        label=${v%%=*} tree=${v#*=}
        integrators=bdpt
        if [ "$tree" = "$here" ] && [ -n "${PARAMS:-}" ]; then integrators="bdpt,bdpt${PARAMS}"; fi
        echo "== $label ($tree) round $round $(date -u +%T)"
        PYTHONUNBUFFERED=1 LIFT_GL_TREE=$tree "$py" "$here/benchmarks/gpu.py" measure $scenes \
            --sizes "${SIZES:-1920x1080}" --integrators "$integrators" --max-depth "${MAX_DEPTH:-32}" --no-rays \
            --label "$label" --out "$out/${label}_$round.json" ${EXTRA:---frames 8 --repeat 2} 2>&1 \
            | grep -v "SceneWarning\|index = self.texture\|^$"
    done
done
files=()
for v in "${versions[@]}"; do
    for f in "$out/${v%%=*}"_*.json; do [ -f "$f" ] && files+=("$f"); done
done
[ ${#files[@]} -gt 0 ] && "$py" "$here/benchmarks/gpu.py" table "${files[@]}" --md "$out/table.md"
exit 0
