#!/usr/bin/env bash
# Submits a dome show to Slurm: an array job, one task per PER_TASK frames
# (dome.sbatch), then the check step (check.sbatch) once every task has
# ended. Prints the two job ids ("ARRAY_ID CHECK_ID").
#
#   scripts/farm/submit-show.sh BINARY SHOW_DIR START..END PER_TASK [--tasks LIST] [--hold] [-- BINARY_ARGS...]
#
# --tasks 2,5 submits only those array tasks (the rerun the check step
# names); --hold submits the array held (release it with scontrol release).
# Example, 4K frames 0..240 in 30 tasks of 8 frames:
#   scripts/farm/submit-show.sh target/release/examples/dome /shared/show 0..240 8 -- --size 4096
set -euo pipefail
here=$(dirname "$(realpath "$0")")
usage="usage: submit-show.sh BINARY SHOW_DIR START..END PER_TASK [--tasks LIST] [--hold] [-- BINARY_ARGS...]"
[ $# -ge 4 ] || { echo "$usage" >&2; exit 2; }
OPTICA_DOME=$(realpath "$1")
SHOW_DIR=$(realpath -m "$2")
range=$3
PER_TASK=$4
shift 4
SHOW_START=${range%%..*}
SHOW_END=${range##*..}
tasks=""
hold=()
while [ $# -gt 0 ]; do
    case $1 in
        --tasks) tasks=$2; shift 2 ;;
        --hold) hold=(--hold); shift ;;
        --) shift; break ;;
        *) echo "$usage" >&2; exit 2 ;;
    esac
done
SHOW_ARGS="$*"
if ! [[ $SHOW_START =~ ^[0-9]+$ && $SHOW_END =~ ^[0-9]+$ && $PER_TASK =~ ^[1-9][0-9]*$ ]] ||
    [ "$SHOW_END" -le "$SHOW_START" ]; then
    echo "submit-show: frames must be START..END with END > START, PER_TASK at least 1" >&2
    exit 2
fi
if [ -z "$tasks" ]; then
    tasks="0-$(((SHOW_END - SHOW_START + PER_TASK - 1) / PER_TASK - 1))"
fi
mkdir -p "$SHOW_DIR"
export OPTICA_DOME SHOW_DIR SHOW_START SHOW_END PER_TASK SHOW_ARGS
array=$(sbatch --parsable "${hold[@]}" --array="$tasks" --chdir="$SHOW_DIR" "$here/dome.sbatch")
check=$(sbatch --parsable --dependency="afterany:$array" --chdir="$SHOW_DIR" "$here/check.sbatch")
echo "$array $check"
