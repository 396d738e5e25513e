#!/usr/bin/env bash
# Builds the Debian package of sceneloc (CPack; cmake/Install.cmake says what it holds):
# portable binaries (no AVX2) installed under /usr, settings in /etc/sceneloc, the systemd
# unit, the manual. Writes OUT_DIR/sceneloc_VERSION_ARCH.deb (default ./package-out).
#   sudo apt-get install ./package-out/sceneloc_*.deb   # then copy maps to /var/lib/sceneloc/maps
# Usage: scripts/package.sh [OUT_DIR]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(mkdir -p "${1:-$root/package-out}" && cd "${1:-$root/package-out}" && pwd)"
bash "$root/scripts/setup.sh"
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
build="$root/build-pkg"
# Without .git (a source archive) the version is the project's; SCENELOC_VERSION overrides.
cmake -S "$root" -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_INSTALL_PREFIX=/usr -DSCENELOC_AVX2=OFF -DSCENELOC_BUILD_TESTS=OFF \
  -DSCENELOC_BUILD_BENCHMARKS=OFF -DSCENELOC_VERSION="${SCENELOC_VERSION:-}" >/dev/null
cmake --build "$build" -j"$(nproc)"
(cd "$build" && cpack -G DEB -B "$out" >/dev/null)
rm -rf "$out/_CPack_Packages"
ls "$out"/sceneloc_*.deb
