#!/bin/bash
# call 1: data (independent / coherent / interleave2 in turn) and two fine-tunings of the shipped model
set -u
export PYTHONUNBUFFERED=1
log() { echo "[$(date +%T)] $*" | tee -a "$OUT/log.txt"; }
nvidia-smi --query-gpu=name,driver_version,clocks.sm --format=csv,noheader | tee -a $OUT/log.txt
S=independent,coherent,interleave2
D=/tmp/ftdata
log "data"
python3 -m lift_gl.denoise.train --out $D --scenes 400 --data-minutes ${DATA_MINUTES:-2.5} --steps 0 --no-export \
    --workers 12 --backend egl --samplings $S 2>&1 | grep -E "data:|Error|error" | tail -8 | tee -a "$OUT/log.txt"
for v in a b; do R=/tmp/ft$v; mkdir -p $R; ln -s $D/train $R/train; ln -s $D/val $R/val
  cp assets/denoiser/train_checkpoint.pt $R/checkpoint.pt; done
log "train"
python3 -m lift_gl.denoise.train --out /tmp/fta --scenes 400 --data-minutes 0 --steps 35000 --schedule-start 30000 \
    --lr 3e-4 --ssim-weight 2.0 --minutes ${TRAIN_MINUTES:-2.7} --onnx $OUT/mixed_a.onnx --backend egl --samplings $S >/tmp/fta/log.txt 2>&1 &
python3 -m lift_gl.denoise.train --out /tmp/ftb --scenes 400 --data-minutes 0 --steps 35000 --schedule-start 30000 \
    --lr 1e-3 --ssim-weight 2.0 --minutes ${TRAIN_MINUTES:-2.7} --onnx $OUT/mixed_b.onnx --backend egl --samplings $S >/tmp/ftb/log.txt 2>&1 &
wait
for v in a b; do grep -E "data: [0-9]+ training|train:|exported|Error|error" /tmp/ft$v/log.txt | tail -16 | sed "s/^/$v /" | tee -a "$OUT/log.txt"
  cp /tmp/ft$v/checkpoint.pt $OUT/mixed_$v.pt; done
log done
