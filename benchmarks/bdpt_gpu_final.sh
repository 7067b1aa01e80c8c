#!/usr/bin/env bash
# The A/B of the bdpt GPU work (docs/bdpt.md "On the GPU"), for one device call: main's bdpt
# (`tree`) against this branch's (`base`) and against its first step alone (`uvec4`, 9eb3e93: the
# stored subpath as uvec4s, the step the first device call timed), trace pass at 1920x1080,
# 1 spp, path length 32, variants dispatched alternately on the same host; on the cheap-to-compile
# scenes also the first light vertices in shared memory (bdpt_shared4/8; the default keeps them
# local) and diagnostics (no s >= 2 joins, per-pixel counts), on the dining room the camera
# subpath alone (what is left). Prepared here with
#   bash benchmarks/bdpt_gpu_diag.sh prepare main DEST TAR uvec4=9eb3e93
# and run there (cwd DEST/new) as   bash benchmarks/bdpt_gpu_final.sh OUTDIR   (about 4.5 minutes)
export VARIANTS_CORNELL=tree,uvec4,base,bdpt_shared4,bdpt_shared8,bdpt_no_connect,bdpt_count_paths
export VARIANTS_DRAGON=tree,uvec4,base,bdpt_shared4
export VARIANTS_DINING=tree,uvec4,base,bdpt_camera_only
export VARIANTS_CLASSROOM=tree,base
export T_CORNELL=${T_CORNELL:-55} T_DRAGON=${T_DRAGON:-45} T_DINING=${T_DINING:-80} T_CLASSROOM=${T_CLASSROOM:-100}
exec bash "$(dirname "$0")/bdpt_gpu_diag.sh" ab "$1"
