#!/usr/bin/env bash
# Every method of the registry on the 2D swinging plate (the set-ups of the
# `swinging-plate` study suite; Upwind- and JST-SPH on the shipped case with its mirror
# planes), on the CPU, with the roofline columns: particle-steps/s, pairs per particle,
# ns per pair, bytes per particle-step and the fraction of the STREAM triad.
#
#   scripts/bench-methods.sh [particles, default 2e4] [steps, default 40]
#
# RAYON_NUM_THREADS sets the threads; MESHLESS the binary (default: the release build).
set -euo pipefail
cd "$(dirname "$0")/.."
sizes=${1:-2e4}
steps=${2:-40}
bin=${MESHLESS:-./target/release/meshless}
plate=cases/studies/cases/swinging-plate.toml
[ -x "$bin" ] || cargo build --release
bench() {
    local name=$1 n=$2
    shift 2
    "$bin" bench "$@" --backend cpu --particles "$sizes" --steps "$n" --roofline |
        grep '^| swinging-plate' | sed "s/^| swinging-plate/| $name/"
}
echo "| method | backend | particles | steps | set-up [s] | particle-steps/s | rate evaluations/s | neighbours [% of steps] | pairs/particle | ns per pair | bytes/particle-step | GB/s | of triad |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
bench tlsph "$steps" "$plate"
bench tlsph-hypoelastic "$steps" "$plate" --set material.model=hypoelastic
bench upwind-sph "$steps" swinging-plate --set method.name=upwind-sph
bench jst-sph "$steps" swinging-plate --set method.name=jst-sph
bench tl-potential "$steps" "$plate" --set method.name=tl-potential
bench corotated-tlsph "$steps" "$plate" --set method.name=corotated-tlsph --set method.correction=none
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
bench efg "$steps" "$plate" --set method.name=efg --set method.kernel=cubic-spline \
    --set method.correction= --set body.0.geometry.volumes=tributary
