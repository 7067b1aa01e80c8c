#!/usr/bin/env bash
# The second device call of the bdpt GPU work (docs/bdpt.md "On the GPU"): main's bdpt (`tree`)
# against this branch's (`base`) and its steps (trees uvec4, joins, walk1: the commits that
# introduced them, see docs/bdpt.md), trace pass at 1920x1080, 1 spp, path length 32, variants
# dispatched alternately on the same host; on the cheap-to-compile scenes also the number of
# light vertices kept in shared memory (bdpt_shared0/8) and, on the dining room, what is left
# (the camera subpath alone). Prepared here with
#   bash benchmarks/bdpt_gpu_diag.sh prepare main DEST TAR uvec4=9eb3e93 joins=38a608d walk1=a3cc580
# and run there (cwd DEST/new) as   bash benchmarks/bdpt_gpu_final.sh OUTDIR
export VARIANTS_CORNELL=tree,uvec4,joins,walk1,base,bdpt_shared0,bdpt_shared8,bdpt_count_paths
export VARIANTS_DRAGON=tree,joins,base,bdpt_shared0
export VARIANTS_DINING=tree,joins,base,bdpt_camera_only
export VARIANTS_CLASSROOM=tree,base
export T_CORNELL=${T_CORNELL:-55} T_DRAGON=${T_DRAGON:-45} T_DINING=${T_DINING:-80} T_CLASSROOM=${T_CLASSROOM:-100}
exec bash "$(dirname "$0")/bdpt_gpu_diag.sh" ab "$1"
