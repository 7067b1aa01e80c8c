# call 6: the closing table with the collapse by cost and children largest box first (the defaults), one process; then ray rates at 1080p
W=/tmp/w; mkdir -p $W/shared; [ -d $W/shared/scenes_lift ] || tar -xJf .devwork/s17/lift_scenes_all.tar.xz -C $W/shared
S=$W/shared/scenes_lift
sed "s#\.\./\.\./shared/assets#$W/shared/assets#;s#\.\./shared/assets#$W/shared/assets#" scenes/covered_dragon.toml > $W/covered_dragon.toml; D=$W/covered_dragon.toml
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
L=pt:rr_depth=1:rr_min_survival=0
python3 benchmarks/gpu.py measure $S/cornell-box/scene.pbrt $S/dining-room/scene.pbrt $S/classroom/scene.pbrt $D --sizes 1280x720,1920x1080 --integrators $L,pt \
  --frames 64 --repeat 2 --no-rays --out $OUT/closing.json 2>&1 | grep -v Warning | grep 'ms/frame\|Error\|error' | head -40
timeout 100 python3 benchmarks/gpu.py measure $S/cornell-box/scene.pbrt $S/dining-room/scene.pbrt $S/classroom/scene.pbrt --sizes 1920x1080 --integrators none \
  --out $OUT/rays.json 2>&1 | grep -v Warning | tail -12
