#!/bin/bash
# Submits a whole `mpm study` to Slurm: a job array of SHARDS shards, then the merge once every
# shard has ended.
#
#   SHARDS=16 STUDY_DIR=/shared/out/study bash examples/slurm/submit.sh
#
# Settings as in study_shard.sbatch, and SHARDS (default 16). Options after the script name
# are passed to both sbatch calls (--partition=..., --account=...).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
SHARDS=${SHARDS:-16}
export STUDY_DIR=${STUDY_DIR:-out/study} STUDY_OPTIONS=${STUDY_OPTIONS:-} MPM=${MPM:-mpm}
array=$(sbatch --parsable --export=ALL "$@" --array="1-$SHARDS" "$here/study_shard.sbatch")
array=${array%%;*}
merge=$(sbatch --parsable --export=ALL "$@" --dependency="afterany:$array" "$here/study_merge.sbatch")
echo "shards: job $array (1-$SHARDS); merge: job ${merge%%;*}; report: $STUDY_DIR/report.md"
