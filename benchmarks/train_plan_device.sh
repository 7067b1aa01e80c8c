#!/usr/bin/env bash
# One session of the denoiser's training plan (python -m lift_gl.denoise.train.plan) on a machine
# that forgets its files between sessions:
#
#   [PYTHON=python3] [RUN=runs/rt] bash benchmarks/train_plan_device.sh OUTDIR PLAN_OPTIONS...
#   e.g. bash benchmarks/train_plan_device.sh "$OUT" --model rt --onnx runs/rt/lift_rt.onnx \
#            --workers 12 --backend egl --time-budget-s 540
#
# runs the plan in RUN (the data renders there again each session, from the scenes' seeds; a
# checkpoint already at RUN/checkpoint.pt is resumed), then copies into OUTDIR what the next
# session needs and what was made: plan.log, status.json, checkpoint.pt (bring it back to
# RUN/checkpoint.pt), and when the plan is done record.json and the ONNX model with its sidecar.
# The exit status is the plan's: 0 done, 3 stopped by the budget (run again).
set -uo pipefail
out=${1:?usage: train_plan_device.sh OUTDIR PLAN_OPTIONS...}
shift
run=${RUN:-runs/rt}
py=${PYTHON:-python3}
mkdir -p "$out" "$run"
"$py" -m lift_gl.denoise.train.plan --out "$run" "$@" 2>&1 | tee "$out/plan.log"
code=${PIPESTATUS[0]}
for f in status.json checkpoint.pt record.json; do
    [ -f "$run/$f" ] && cp "$run/$f" "$out/"
done
onnx=$("$py" -c "import json,sys; print(json.load(open(sys.argv[1])).get('onnx', ''))" "$run/status.json" 2>/dev/null)
if [ -n "$onnx" ] && [ -f "$onnx" ]; then
    cp "$onnx" "${onnx%.onnx}.json" "$out/"
fi
exit "$code"
