#!/usr/bin/env bash
# The check a GPU owner runs and attaches to a report: the adapter, the GPU tests (the
# WGSL shaders against the f64 CPU reference), `meshless bench` on the GPU for every
# method of the registry on the 2D swinging plate (scripts/bench-methods.sh's set-ups),
# each with its per-pass report (time, bytes of the model, GB/s), and TLSPH there at the
# largest size the device's and the host's memory hold. It writes one markdown file.
#
#   scripts/gpu-check.sh [OUT.md]            # sizes 1e5 and 1e6 particles, 100 steps
#   scripts/gpu-check.sh --small [OUT.md]    # 1e3 particles, 10 steps, no tests, the
#                                            # largest size in 16 MB (CI, lavapipe)
#
# SIZES and STEPS override the sizes (comma-separated particle counts) and steps; FEATURES
# (say `mpi`) builds with those cargo features besides the default ones. Needs
# what the tests need (Rust, a Vulkan, Metal or DX12 driver); `nvidia-smi` is read when
# present. On an H100 or H200 the default run takes about 5 minutes after the build (the
# bench set-ups build neighbour lists on the host, 1e6 particles in seconds).
set -euo pipefail
cd "$(dirname "$0")/.."
small=false
if [ "${1:-}" = --small ]; then
    small=true
    shift
fi
if $small; then
    sizes=${SIZES:-1e3}
    steps=${STEPS:-10}
    largest_steps=2
else
    sizes=${SIZES:-1e5,1e6}
    steps=${STEPS:-100}
    largest_steps=20
fi
out=${1:-gpu-check-$(hostname)-$(date -u +%Y%m%d-%H%M).md}
if [ -z "${XDG_RUNTIME_DIR:-}" ] || [ ! -d "${XDG_RUNTIME_DIR}" ]; then
    XDG_RUNTIME_DIR=$(mktemp -d)
    export XDG_RUNTIME_DIR
fi
cargo build --release --quiet --features "${FEATURES:-}"
start=$(date +%s)
{
    echo "# meshless GPU check"
    echo
    echo "- date (UTC): $(date -u '+%Y-%m-%d %H:%M')"
    echo "- commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet 2>/dev/null || echo ' (with local changes)')"
    echo "- host: $(nproc) cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
    echo "- $(rustc --version)"
    if command -v nvidia-smi >/dev/null; then
        echo "- nvidia-smi: $(nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader | head -1)"
    fi
    echo "- sizes: $sizes particles, $steps steps"
    echo
    if ! $small; then
        echo "## GPU tests"
        echo
        echo '```'
        test_start=$(date +%s)
        tests=passed
        log=$(cargo test --release --features "${FEATURES:-}" --test it gpu 2>&1) || tests=FAILED
        grep -E '^test result|FAILED|panicked' <<<"$log" || true
        echo "GPU tests $tests ($(($(date +%s) - test_start)) s)"
        echo '```'
        echo
    fi
    echo "## Throughput and passes, every method on the GPU"
    echo
    echo "The 2D swinging plate, each method with its set-up of \`scripts/bench-methods.sh\`;"
    echo "the bound under each pass report is the model's bytes at the adapter's copy bandwidth."
    BACKEND=gpu scripts/bench-methods.sh "$sizes" "$steps"
    echo
    echo "## The largest TLSPH run that fits"
    echo
    # The most particles the device's memory and the host's hold by the estimate, a tenth
    # kept free (`meshless bench --particles largest`). A software adapter states no memory
    # of its own, so the small check states 16 MB to keep the run small.
    if $small; then
        memory=${MESHLESS_DEVICE_MEMORY:-16MB}
    else
        memory=${MESHLESS_DEVICE_MEMORY:-}
    fi
    echo "TLSPH on the plate (the set-up of \`scripts/bench-methods.sh\`), sized to the device's"
    echo "memory (${memory:-as the platform reports it}) and the host's, $largest_steps steps:"
    echo
    env ${memory:+MESHLESS_DEVICE_MEMORY=$memory} ./target/release/meshless bench \
        cases/studies/cases/swinging-plate.toml --backend gpu --particles largest \
        --max-particles 1e10 --steps "$largest_steps" 2>&1 | grep -v '^note:'
    echo
    echo "Wall time of the check after the build: $(($(date +%s) - start)) s."
} >"$out"
echo "gpu-check: wrote $out ($(($(date +%s) - start)) s)"
# A failed GPU test fails the check, after the report is written.
grep -q '^GPU tests FAILED' "$out" && exit 1 || true
