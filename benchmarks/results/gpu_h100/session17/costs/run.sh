# call 2: the cost-optimal collapse's costs, three scenes, 1080p, Lift's roulette
W=/tmp/w; mkdir -p $W/shared; [ -d $W/shared/scenes_lift ] || tar -xJf .devwork/s17/lift_scenes_all.tar.xz -C $W/shared
S=$W/shared/scenes_lift
sed "s#\.\./\.\./shared/assets#$W/shared/assets#;s#\.\./shared/assets#$W/shared/assets#" scenes/covered_dragon.toml > $W/covered_dragon.toml; D=$W/covered_dragon.toml
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
L=pt:rr_depth=1:rr_min_survival=0
python3 benchmarks/gpu.py measure $S/dining-room/scene.pbrt $S/classroom/scene.pbrt $D --sizes 1920x1080 --integrators $L \
  --frames 64 --repeat 2 --no-rays --split-rounds 2 --env "LIFT_GL_BVH_COLLAPSE=sah:1/0.3/0.6,sah:1/0.3/0.8,sah:1/0.3/1.0,sah:1/0.5/0.6" --out $OUT/costs.json 2>&1 | grep -v Warning | grep 'ms/frame\|Error\|error' | head -80
