#!/usr/bin/env bash
# Bit-for-bit reference states of shipped cases, for refactors that must not change
# behaviour.
#
#   scripts/reference-states.sh record    # write tests/reference-states/SHA256SUMS
#   scripts/reference-states.sh compare   # run again and compare with it
#
# Each case runs a few dozen steps on the CPU at one thread (RAYON_NUM_THREADS=1, so
# that every sum is taken in one order), with frames; its state is the last frame (every
# f64 field, binary, as the .vtu holds it) and series.csv. The list covers every method
# family, contact, plasticity, mirrors, the static path, 2D and 3D, and all four
# integrators. The states depend on the compiler and the CPU's floating point, so record
# and compare on the same machine: record on the commit before a refactor, then compare
# after each of its steps. A mismatch names the case and the file; the run folders stay
# in the work folder that the script prints. FEATURES (say `mpi`) builds with those cargo
# features besides the default ones, as scripts/test.sh's build has.
set -euo pipefail
cd "$(dirname "$0")/.."

mode=${1:-}
if [ "$mode" != record ] && [ "$mode" != compare ]; then
    echo "usage: $0 record|compare" >&2
    exit 2
fi
sums=tests/reference-states/SHA256SUMS

# name | case | overrides (a few dozen steps of each)
cases=(
    "tlsph-rk4|pulled-strip|run.end_time=3e-4"
    "tlsph-contact|rings-impact|run.end_time=2e-5"
    "tlsph-leapfrog|rod-gaussian|run.end_time=2e-6"
    "tlsph-3d-ssp-rk3|spinning-block-3d|run.end_time=2e-3"
    "tl-potential-contact|rings-impact-potential|run.end_time=2e-5"
    "corotated-contact|rings-impact-corotated|run.end_time=2e-5"
    "gray-monaghan|rotating-disk-gray-monaghan|run.end_time=5e-4"
    "godunov|rotating-disk-godunov|run.end_time=5e-5"
    "upwind-tvd-rk2-mirror-plastic|taylor-bar|run.end_time=5e-7"
    "jst-ssp-rk3-mirrors|swinging-plate-seed002|run.end_time=2e-3"
    "upwind-3d|twisting-column|run.end_time=2e-3"
    "tl-weak-form-contact|rings-impact-weak-form|run.end_time=1.5e-5"
    "tl-fem-contact|rings-impact-fem|run.end_time=2e-5"
    "ul-weak-form|rotating-disk-ul-weak-form|run.end_time=5e-5"
    "ul-fem-contact|rings-impact-ul-fem|run.end_time=2e-5"
    "kbm-plastic-leapfrog|steel-ring-kbm|run.end_time=2e-5"
    "efg-leapfrog|rod-gaussian-efg|run.end_time=1e-6"
    "static-tlsph|cantilever-convergence|"
    "static-tl-fem|beam-gravity|"
    "static-dual-support|plate-compression-2d|"
    "dual-support-dynamic|bar-mode|method.name=dual-support-sph run.solve=dynamic run.end_time=5e-3"
)

cargo build --release --quiet --features "${FEATURES:-}"
work=$(mktemp -d)
echo "runs in $work"
export RAYON_NUM_THREADS=1
for entry in "${cases[@]}"; do
    IFS='|' read -r name case overrides <<<"$entry"
    sets=()
    for o in $overrides; do sets+=(--set "$o"); done
    ./target/release/meshless run "$case" --backend cpu --out "$work/$name" -q \
        --set output.check= "${sets[@]}" >"$work/$name.log" 2>&1 || {
        echo "$name ($case) failed:" >&2
        cat "$work/$name.log" >&2
        exit 1
    }
    last=$(ls "$work/$name"/*.vtu | sort | tail -1)
    cp "$last" "$work/$name/last.vtu"
done
(cd "$work" && for entry in "${cases[@]}"; do
    name=${entry%%|*}
    sha256sum "$name/last.vtu" "$name/series.csv"
done) >"$work/SHA256SUMS"

if [ "$mode" = record ]; then
    cp "$work/SHA256SUMS" "$sums"
    echo "recorded ${#cases[@]} cases in $sums"
else
    if diff <(sort -k2 "$sums") <(sort -k2 "$work/SHA256SUMS") >"$work/diff"; then
        echo "all ${#cases[@]} cases bit-identical to $sums"
    else
        echo "states differ from $sums (< recorded, > now):" >&2
        cat "$work/diff" >&2
        exit 1
    fi
fi
