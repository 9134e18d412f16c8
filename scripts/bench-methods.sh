#!/usr/bin/env bash
# Every method of the registry on the 2D swinging plate (the set-ups of the
# `swinging-plate` study suite; Upwind- and JST-SPH on the shipped case with its mirror
# planes), on the CPU, with the roofline columns: particle-steps/s, pairs per particle,
# ns per pair, bytes per particle-step and the fraction of the STREAM triad.
#
#   scripts/bench-methods.sh [particles, default 2e4] [steps, default 40]
#   scripts/bench-methods.sh --instructions [particles, default 5e3] [steps, default 8]
#
# With --instructions every method runs on one thread under valgrind's callgrind, twice
# (`steps` and 2·`steps` steps), and the table gives the instructions one step adds per
# pair and rate evaluation: a count that, unlike a time, does not move with the host's
# load. It also gives the f64 operations among them (scripts/flops.py: each lane of an
# add, subtract, multiply, divide, square root, min or max, two per fused multiply-add)
# and the instructions per f64 operation, which tell the arithmetic a method's
# equations ask for from what the code spends around it. RAYON_NUM_THREADS sets the
# threads; MESHLESS the binary (default: the release build); METHODS a regular
# expression that picks the methods to run (default: all); PLATE and MIXED the cases in
# place of the plate and of the mixed family's shipped plate (`PLATE=spinning-block-3d
# MIXED=twisting-column` for 3D). BACKEND=gpu runs them on the
# GPU instead: for each method a heading, its table (particle counts comma-separated, as
# `meshless bench --particles` takes them) and its pass report; a method without a GPU
# engine says so.
set -euo pipefail
cd "$(dirname "$0")/.."
count=false
if [ "${1:-}" = --instructions ]; then
    count=true
    shift
fi
if $count; then
    sizes=${1:-5e3}
    steps=${2:-8}
else
    sizes=${1:-2e4}
    steps=${2:-40}
fi
bin=${MESHLESS:-./target/release/meshless}
plate=${PLATE:-cases/studies/cases/swinging-plate.toml}
mixed=${MIXED:-swinging-plate}
[ -x "$bin" ] || cargo build --release
for tool in valgrind objdump python3; do
    if $count && ! command -v $tool >/dev/null; then
        echo "bench-methods.sh --instructions needs valgrind, objdump and python3" \
            "(Debian: apt-get install valgrind binutils python3); $tool is missing" >&2
        exit 1
    fi
done
# The instructions and f64 operations of a bench run of $1 steps (the rest of the
# arguments), and its table row.
instructions() {
    local n=$1 out profile
    shift
    out=$(mktemp)
    profile=$(mktemp)
    RAYON_NUM_THREADS=1 valgrind --tool=callgrind --dump-instr=yes --dump-line=no \
        --callgrind-out-file="$profile" \
        "$bin" bench "$@" --backend cpu --particles "$sizes" --steps "$n" >"$out" 2>&1
    local flops
    flops=$(python3 scripts/flops.py "$profile" "$(realpath "$bin")")
    echo "$(grep -o 'Collected : [0-9]*' "$out" | grep -o '[0-9]*$') ${flops#* } $(grep -v '^| case |' "$out" | grep -m1 '^| [a-z]')"
    rm -f "$out" "$profile"
}
bench() {
    local name=$1 n=$2
    shift 2
    [[ $name =~ ^(${METHODS:-.*})$ ]] || return 0
    if $count; then
        local a b
        a=$(instructions "$n" "$@")
        b=$(instructions $((2 * n)) "$@")
        # Of the row split at '|': particles $4, particle-steps/s $7, rate
        # evaluations/s $8, pairs/particle $10.
        read -r ir_a fl_a row <<<"$a"
        read -r ir_b fl_b _ <<<"$b"
        echo "$row" | awk -F'|' -v name="$name" -v n="$n" -v ia="$ir_a" -v ib="$ir_b" \
            -v fa="$fl_a" -v fb="$fl_b" '{
            particles = $4; evaluations = $8 / $7; pairs = $10
            per_step = (ib - ia) / n; flops = (fb - fa) / n
            per_pair = particles * evaluations * pairs
            printf "| %s | %d | %.1f | %.0f | %.0f | %.1f | %.1f | %.2f |\n", name, particles, pairs,
                evaluations, per_step / particles, per_step / per_pair, flops / per_pair, per_step / flops
        }'
    elif [ "${BACKEND:-cpu}" = gpu ]; then
        printf '\n### %s\n\n' "$name"
        local out
        if ! out=$("$bin" bench "$@" --backend gpu --particles "$sizes" --steps "$n" 2>&1); then
            # A method without a GPU engine is said so; any other failure fails the script.
            grep -q 'has no GPU engine' <<<"$out" || { echo "$out" >&2; exit 1; }
        fi
        grep -v '^note:' <<<"$out"
    else
        "$bin" bench "$@" --backend cpu --particles "$sizes" --steps "$n" --roofline |
            grep -v '^| case |' | grep '^| [a-z]' | sed "s/^| [^|]*|/| $name |/"
    fi
}
if [ "${BACKEND:-cpu}" = gpu ]; then
    :
elif $count; then
    echo "| method | particles | pairs/particle | rate evaluations/step | instructions/particle-step | instructions per pair and evaluation | f64 operations per pair and evaluation | instructions per f64 operation |"
    echo "|---|---|---|---|---|---|---|---|"
else
    echo "| method | backend | particles | steps | set-up [s] | particle-steps/s | rate evaluations/s | neighbours [% of steps] | pairs/particle | ns per pair | device B/particle | bytes/particle-step | GB/s | of triad |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
fi
bench tlsph "$steps" "$plate"
bench tlsph-hypoelastic "$steps" "$plate" --set material.model=hypoelastic
bench upwind-sph "$steps" "$mixed" --set method.name=upwind-sph
bench jst-sph "$steps" "$mixed" --set method.name=jst-sph
# The plate's `force = "reveles"` is TLSPH's: the potential takes its own default, corotated
# TLSPH the reference code's force of its suite variant.
bench tl-potential "$steps" "$plate" --set method.name=tl-potential --set method.force=
bench corotated-tlsph "$steps" "$plate" --set method.name=corotated-tlsph --set method.correction=none \
    '--set=method.force="reference-code"'
bench gray-monaghan-sph "$steps" "$plate" --set method.name=gray-monaghan-sph \
    --set material.model=hypoelastic --set method.kernel=cubic-spline --set method.correction=none \
    "--set=method.artificial_viscosity={ alpha = 1.0, beta = 1.0, eta = 0.1 }" \
    "--set=method.artificial_stress={ epsilon = 0.3, n = 4.0 }" --set method.xsph=0.5
bench godunov-sph "$steps" "$plate" --set method.name=godunov-sph --set material.model=hypoelastic \
    --set method.kernel=cubic-spline --set method.h_over_dx=1.7 --set method.correction=none
bench dual-support-sph "$steps" "$plate" --set method.name=dual-support-sph \
    --set method.correction= --set run.solve=dynamic
bench tl-weak-form "$steps" "$plate" --set method.name=tl-weak-form \
    --set method.kernel=cubic-spline --set method.correction=
bench tl-fem "$steps" "$plate" --set method.name=tl-fem --set method.kernel= \
    --set method.h_over_dx= --set method.correction=
bench ul-fem "$steps" "$plate" --set method.name=ul-fem --set method.kernel= \
    --set method.h_over_dx= --set method.correction=
# The updated-Lagrangian weak form recomputes its RKPM functions every stage: fewer steps.
bench ul-weak-form $(( (steps + 7) / 8 )) "$plate" --set method.name=ul-weak-form \
    --set material.model=hypoelastic --set method.kernel= --set method.h_over_dx= --set method.correction=
bench kbm "$steps" "$plate" --set method.name=kbm --set method.kernel=cubic-spline \
    --set method.correction= --set body.0.geometry.volumes=tributary
bench kbm-eulerian "$steps" "$plate" --set method.name=kbm --set method.kernel=cubic-spline \
    --set method.correction= --set body.0.geometry.volumes=tributary \
    --set method.kernel_frame=eulerian
bench efg "$steps" "$plate" --set method.name=efg --set method.kernel=cubic-spline \
    --set method.correction= --set body.0.geometry.volumes=tributary
