#!/usr/bin/env bash
# The dome show on a real Slurm: starts a one-node cluster on the loopback
# (local-slurm.sh; installs slurm-wlm and munge when missing, as root),
# renders frames 0..8 at 64² as an array job of 4 tasks × 2 frames with
# task 2 killed before it runs, checks that the final step names frames 4
# and 5 and task 2, reruns only task 2, and compares every frame bit for
# bit with the same frames rendered in one process.
#
#   scripts/farm/slurm-test.sh [DOME_BINARY]   (default target/debug/examples/dome)
set -euo pipefail
root=$(dirname "$(realpath "$0")")/../..
binary=$(realpath "${1:-$root/target/debug/examples/dome}")
[ -x "$binary" ] || { echo "slurm-test: no dome binary at $binary (cargo build --example dome --features dome)" >&2; exit 1; }
start_s=$(date +%s)
work=$(mktemp -d /tmp/optica-slurm.XXXXXX)
# shellcheck source=local-slurm.sh
source "$root/scripts/farm/local-slurm.sh" "$work/cluster"
trap 'local_slurm_stop; echo "slurm-test: logs and frames in $work"' EXIT
args=(--size 64)

# Waits until job $1 has left the queue; prints its exit code (status:signal).
wait_job() {
    for _ in $(seq 1 600); do
        if ! squeue -h -j "$1" 2>/dev/null | grep -q .; then
            scontrol show job "$1" | sed -n 's/.* ExitCode=\([0-9:]*\).*/\1/p'
            return 0
        fi
        sleep 0.5
    done
    echo "slurm-test: job $1 still queued after 300 s" >&2
    squeue >&2
    return 1
}
fail() {
    echo "slurm-test: FAILED: $*" >&2
    exit 1
}

# The reference: the whole show in one process.
"$binary" --export "$work/one-process" --frames 0..8 "${args[@]}" >"$work/one-process.log" 2>&1 ||
    fail "the one-process render failed ($work/one-process.log)"

# The farm, with task 2 (frames 4 and 5) killed before it starts.
read -r array check < <("$root/scripts/farm/submit-show.sh" "$binary" "$work/show" 0..8 2 --hold -- "${args[@]}")
scancel "${array}_2"
scontrol release "$array"
status=$(wait_job "$check")
log="$work/show/slurm-optica-dome-check-$check.out"
cat "$log"
[ "$status" = "1:0" ] || fail "the check step's exit code is $status, not 1, with task 2 killed"
grep -q "2 of 8 frames missing in .*: 4 5$" "$log" || fail "the check step does not name frames 4 and 5"
grep -q "rerun array tasks 2 " "$log" || fail "the check step does not name task 2"

# The rerun of the missing task alone completes the show.
read -r array check < <("$root/scripts/farm/submit-show.sh" "$binary" "$work/show" 0..8 2 --tasks 2 -- "${args[@]}")
status=$(wait_job "$check")
cat "$work/show/slurm-optica-dome-check-$check.out"
[ "$status" = "0:0" ] || fail "the check step's exit code after the rerun is $status, not 0"

# Every frame, bit for bit.
same=0
for f in $(seq 0 7); do
    name=$(printf 'domemaster_%06d.png' "$f")
    if cmp -s "$work/one-process/$name" "$work/show/$name"; then
        same=$((same + 1))
    else
        echo "slurm-test: frame $f differs from the one-process render" >&2
    fi
done
[ "$same" = 8 ] || fail "$same of 8 frames bit for bit"
# The show moves: blank or frozen frames would also compare equal.
if cmp -s "$work/one-process/domemaster_000000.png" "$work/one-process/domemaster_000007.png"; then
    fail "frames 0 and 7 of the one-process render are the same image"
fi
echo "slurm-test: passed: 4 tasks × 2 frames at 64², task 2 killed and rerun alone," \
    "8 of 8 frames bit for bit equal to one process, in $(($(date +%s) - start_s)) s"
