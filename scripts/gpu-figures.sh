#!/usr/bin/env bash
# The absolute GPU figures of every plugin, beside their goals, on a machine
# that has a GPU and a Vulkan driver but no Rust toolchain.
#
# Here (with Rust 1.95):
#   scripts/gpu-figures.sh build [DIR]   # release build, stripped, into DIR (default gpu-run/)
# Copy DIR to the GPU machine (the binary is ~40 MB; it needs the Vulkan
# loader, libvulkan.so.1, and the GPU's driver: on Debian/Ubuntu
# `apt-get install libvulkan1`, or unpack the libvulkan1 .deb beside it and
# point LD_LIBRARY_PATH at it), then there:
#   DIR/gpu-figures.sh run [OUT]         # writes OUT/gpu.json, gpu.md, gpu.png, gpu.svg (default gpu-figures/)
#
# `run` uses the first GPU wgpu finds (--adapter auto) and refuses a CPU
# device (lavapipe, llvmpipe): on such a machine the figures mean nothing.
# It takes under 5 minutes on a current GPU. To try it on lavapipe anyway:
#   DIR/gpu-figures.sh run OUT --quick --allow-cpu
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
case "${1:-}" in
build)
    dir="${2:-gpu-run}"
    cd "$here/.."
    cargo build --release --locked -p optica_report
    mkdir -p "$dir"
    cp target/release/optica_report "$dir/"
    strip "$dir/optica_report"
    cp "$here/gpu-figures.sh" "$dir/"
    ls -la "$dir"
    ;;
run)
    out="${2:-gpu-figures}"
    shift $(( $# >= 2 ? 2 : 1 ))
    # A Vulkan loader unpacked beside the binary (dpkg -x libvulkan1_*.deb lib)
    # is used when the system has none.
    if [ -d "$here/lib" ]; then
        export LD_LIBRARY_PATH="$here/lib/usr/lib/x86_64-linux-gnu:${LD_LIBRARY_PATH:-}"
    fi
    "$here/optica_report" gpu --adapter auto --out "$out" "$@"
    echo "figures: $out/gpu.md"
    ;;
*)
    sed -n '2,18p' "$0"
    exit 2
    ;;
esac
