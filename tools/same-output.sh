#!/usr/bin/env bash
# Checks that a change kept tether's outputs byte for byte (issue 18: a refactor keeps
# the demo's table and replay's bytes as they were).
#
#   tools/same-output.sh OLD_REV [NEW_REV]
#
# Builds the release binary of both revisions (NEW_REV defaults to the working tree)
# and runs each on the same inputs:
#   - `tether demo` (every built-in scenario: the printed table, report.html and each
#     scenario's metrics.json),
#   - `tether sim --scenario occlusion --seed 3` (sensor data, ground truth, picture,
#     its MCAP recording),
#   - `tether replay` of that recording (result MCAP and report),
#   - `tether track` and `tether legs` of a real recording from ../shared (when present).
# Then compares every file and every stdout with `cmp`. Exit status 0 when all are
# identical, 1 with the list of what differs.
#
# The old revision (and NEW_REV when given) builds in target folders of its own under
# target/same-output, kept for the next run; the first run builds the dependencies
# there once (about ten minutes on two cores), later ones only what changed.
set -Eeuo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

if [ $# -lt 1 ] || [ $# -gt 2 ]; then
    echo "usage: tools/same-output.sh OLD_REV [NEW_REV]" >&2
    exit 2
fi
old_rev=$1
new_rev=${2:-}

export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$root/target}
# Kept in a fixed place between runs, so that a second run against the same revisions
# builds nothing again.
work=$CARGO_TARGET_DIR/same-output
mkdir -p "$work"
rm -rf "$work/old-out" "$work/new-out"
trap 'echo "a command failed; the logs are in $work" >&2' ERR

# checkout NAME REV: the source of REV at $work/NAME, reused when it is already there.
checkout() {
    local dir="$work/$1" commit
    commit=$(git -C "$root" rev-parse --verify "$2^{commit}")
    if [ -d "$dir" ] && [ "$(git -C "$dir" rev-parse HEAD 2>/dev/null)" = "$commit" ]; then
        return
    fi
    git -C "$root" worktree remove --force "$dir" >/dev/null 2>&1 || rm -rf "$dir"
    git -C "$root" worktree prune
    git -C "$root" worktree add --quiet --detach "$dir" "$commit"
}

# build NAME SOURCE_DIR TARGET_DIR: the release binary of SOURCE_DIR as
# $work/NAME-tether. Each checkout builds in a target folder of its own: two checkouts
# of one workspace give their crates the same artifact names, and in one folder cargo
# would take the other checkout's artifacts for up to date.
build() {
    echo "== building $1 ($2)"
    CARGO_TARGET_DIR=$3 cargo build --quiet --release --locked -p tether \
        --manifest-path "$2/Cargo.toml"
    cp "$3/release/tether" "$work/$1-tether"
}

checkout old "$old_rev"
build old "$work/old" "$work/target-old"
if [ -n "$new_rev" ]; then
    checkout new "$new_rev"
    build new "$work/new" "$work/target-new"
else
    build new "$root" "$CARGO_TARGET_DIR"
fi

shared="$root/../shared/data/laser/leg_tracker"

# run NAME: every output of the binary NAME-tether in $work/NAME-out.
run() {
    local bin="$work/$1-tether" out="$work/$1-out" log="$work/$1-log"
    mkdir -p "$out"
    # stderr (log lines, progress) is kept apart and not compared.
    exec 3>"$log"
    echo "== running $1"
    (cd "$out" && "$bin" demo --out demo >demo.stdout 2>&3)
    (cd "$out" && "$bin" sim --scenario occlusion --seed 3 --out sim \
        --record sim.mcap >sim.stdout 2>&3)
    (cd "$out" && "$bin" replay sim.mcap --out replay.mcap >replay.stdout 2>&3)
    if [ -d "$shared" ]; then
        (cd "$out" && "$bin" track "$shared/demo_stationary_simple_environment.bag" \
            --scan-topic /scan --out track.jsonl >track.stdout 2>&3)
        (cd "$out" && "$bin" legs "$shared/positive_6_extracted.bag" \
            --topic /training_scan --out legs.jsonl >legs.stdout 2>&3)
    else
        echo "   ($shared is absent: track and legs on real recordings not compared)"
    fi
    exec 3>&-
}
run old
run new

echo "== comparing"
differ=0
compared=0
while IFS= read -r file; do
    compared=$((compared + 1))
    if ! cmp -s "$work/old-out/$file" "$work/new-out/$file"; then
        echo "differs: $file"
        differ=1
    fi
done < <(cd "$work/old-out" && find . -type f | sort)
while IFS= read -r file; do
    if [ ! -e "$work/old-out/$file" ]; then
        echo "only in $new_rev: $file"
        differ=1
    fi
done < <(cd "$work/new-out" && find . -type f | sort)
if [ "$differ" = 0 ]; then
    echo "identical: $compared files (old $old_rev, new ${new_rev:-working tree})"
fi
exit "$differ"
