#!/bin/bash
# Fine-tune the shipped denoiser (assets/denoiser/train_checkpoint.pt, step 21000) with larger
# SSIM weights in the loss, two runs sharing one GPU (docs/denoiser.md, "Training record").
# Run on the GPU machine from the repo root; writes OUT/r{08,20}.{onnx,json,pt} and OUT/log.txt.
set -u
OUT=${OUT:?set OUT}
D=/tmp/ftdata
log() { echo "[$(date +%T)] $*" | tee -a "$OUT/log.txt"; }
log "data: up to 400 training scenes + 8 validation scenes"
python3 -m lift_gl.denoise.train --out $D --scenes 400 --data-minutes ${DATA_MINUTES:-2.5} --steps 0 --no-export \
    --workers 10 --backend egl 2>&1 | grep -v "^render" | tail -5 | tee -a "$OUT/log.txt"
for w in 08 20; do
  R=/tmp/ft$w; mkdir -p $R; ln -s $D/train $R/train; ln -s $D/val $R/val
  cp assets/denoiser/train_checkpoint.pt $R/checkpoint.pt
  python3 -m lift_gl.denoise.train --out $R --scenes 400 --data-minutes 0 --steps 24000 --schedule-start 21000 --lr 5e-4 \
      --ssim-weight ${w:0:1}.${w:1:1} --minutes ${TRAIN_MINUTES:-2.8} --onnx $OUT/r$w.onnx --workers 1 --backend egl \
      >$R/log.txt 2>&1 &
done
wait
for w in 08 20; do grep -E "data: [0-9]+ training|train:|exported|Error|error" /tmp/ft$w/log.txt | tail -12 | sed "s/^/r$w /" | tee -a "$OUT/log.txt"
  cp /tmp/ft$w/checkpoint.pt $OUT/r$w.pt; done
log done
