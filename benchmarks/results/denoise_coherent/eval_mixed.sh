#!/bin/bash
# call 2: the denoiser benchmark's inputs in three samplings, and the shipped model against the two fine-tunings
set -u
export PYTHONUNBUFFERED=1
W=/tmp/w; mkdir -p $W/shared; tar -xJf .devwork/s16/lift_scenes.tar.xz -C $W/shared
nvidia-smi --query-gpu=name,driver_version,clocks.sm --format=csv,noheader | tee -a $OUT/log.txt
S=independent,coherent,interleave2
E=/tmp/eval
python3 benchmarks/denoise_quality.py render --out $E --shared-dir $W/shared/scenes_lift --samplings $S --backend egl 2>&1 | tee -a $OUT/log.txt
M=.devwork/s16/models
python3 benchmarks/denoise_quality.py evaluate $E/*.npz --denoisers onnx,onnx:$M/mixed_a.onnx,onnx:$M/mixed_b.onnx \
    --out $OUT/denoise_quality_samplings.md --images /tmp/img 2>&1 | tail -60
(cd /tmp/img && tar -cf $OUT/strips.tar val0_4spp* val3_4spp* dining-room_4spp* cornell-box_4spp*)
date | tee -a $OUT/log.txt
