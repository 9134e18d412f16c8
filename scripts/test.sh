#!/usr/bin/env bash
# The whole test suite: formatting, lints (with and without the default features), then
# every test in release mode (the numerical tests integrate thousands of steps and are
# written for optimised builds).
#
# The GPU tests run the WGSL shaders on whatever adapter wgpu finds; on a machine without
# a GPU that is Mesa's lavapipe (Vulkan on the CPU), installed here when it is missing.
# A GPU test without any adapter fails: it does not skip. The MPI tests run under MPICH's
# mpirun, installed here when it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! ls /usr/share/vulkan/icd.d/*.json >/dev/null 2>&1; then
    echo "installing Mesa's Vulkan drivers (lavapipe) for the GPU tests"
    sudo_cmd=""
    [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
    $sudo_cmd apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends \
        mesa-vulkan-drivers libvulkan1 >/dev/null
fi
# MPICH (and libclang for the MPI bindings) for the distributed runs under mpirun.
if ! command -v mpicc >/dev/null 2>&1 || ! command -v mpirun >/dev/null 2>&1; then
    echo "installing MPICH and libclang for the MPI tests"
    sudo_cmd=""
    [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
    $sudo_cmd apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends \
        libmpich-dev mpich libclang-dev >/dev/null
fi
# The Vulkan loader's Wayland probe complains without a runtime directory.
if [ -z "${XDG_RUNTIME_DIR:-}" ] || [ ! -d "${XDG_RUNTIME_DIR}" ]; then
    XDG_RUNTIME_DIR=$(mktemp -d)
    export XDG_RUNTIME_DIR
fi

cargo fmt --all -- --check
# The CPU library alone (no GPU backend, command line or studies) builds and is clean.
cargo clippy --no-default-features --all-targets -- -D warnings
# The default build (the code a build without MPI compiles) is clean.
cargo clippy --release --all-targets -- -D warnings
# Every test, in one release build with MPI (feature `mpi`): the unit and integration
# tests, and the distributed runs under mpirun on 2 and 3 ranks, oversubscribed on the
# cores there are (MPICH's Hydra places them without binding; a waiting rank polls and
# yields its core). One build, not one per feature set: the library's release build is
# most of the suite's time.
cargo clippy --release --features mpi --all-targets -- -D warnings
cargo test --release --features mpi
# The GPU owners' check at its smallest, on whatever adapter the tests used: every method's
# GPU bench and pass report run (a method without a GPU engine is said so).
FEATURES=mpi scripts/gpu-check.sh --small "$(mktemp --suffix=.md)"
