# call 5: wide nodes' slots largest box first (shadow rays take them in slot order); the carry memory first written by the GPU
W=/tmp/w; mkdir -p $W/shared; [ -d $W/shared/scenes_lift ] || tar -xJf .devwork/s17/lift_scenes_all.tar.xz -C $W/shared
S=$W/shared/scenes_lift
sed "s#\.\./\.\./shared/assets#$W/shared/assets#;s#\.\./shared/assets#$W/shared/assets#" scenes/covered_dragon.toml > $W/covered_dragon.toml; D=$W/covered_dragon.toml
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
L=pt:rr_depth=1:rr_min_survival=0
python3 benchmarks/gpu.py measure $S/dining-room/scene.pbrt $S/classroom/scene.pbrt $D --sizes 1920x1080 --integrators $L \
  --frames 64 --repeat 2 --no-rays --split-rounds 2 --env "LIFT_GL_BVH_SLOT_ORDER=build,area" --out $OUT/slot_order.json 2>&1 | grep -v Warning | grep 'ms/frame\|Error\|error' | head -40
python3 benchmarks/gpu.py measure $S/dining-room/scene.pbrt $S/cornell-box/scene.pbrt --sizes 1920x1080 --integrators $L \
  --frames 64 --repeat 2 --no-rays --env "LIFT_GL_CARRY_CLEAR=off,gpu" --out $OUT/carry_gpu.json 2>&1 | grep -v Warning | grep 'ms/frame\|Error\|error' | head -40
python3 - <<'PY'
import json, os, glob
for f in sorted(glob.glob(os.environ["OUT"] + "/carry_gpu*.json")):
    d = json.load(open(f))
    for r in d["results"]:
        print(os.path.basename(f), r["scene_name"], r.get("carry_tuning_blocks_ms"))
PY
