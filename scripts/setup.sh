#!/usr/bin/env bash
# Installs every Debian 12 package sceneloc needs to build, test and run.
# Idempotent: packages already present are left alone. Run as root (or with sudo).
# Usage: scripts/setup.sh [--plots] [--clang] [--fuzz]
#   --plots  adds what the evaluation scripts plot with: python3-matplotlib, numpy, scipy
#   --clang  adds clang and its sanitizer runtimes (scripts/sanitize.sh)
#   --fuzz   the same as --clang: libFuzzer comes with them (scripts/fuzz.sh)
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git clang-format
  libopencv-dev libeigen3-dev
  # JPEG and PNG through their own libraries: the installed programs need no imgcodecs.
  libturbojpeg0-dev libpng-dev
  libzmq3-dev cppzmq-dev
  libprotobuf-dev protobuf-compiler
  prometheus-cpp-dev libcivetweb-dev
  libspdlog-dev libfmt-dev libyaml-cpp-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev nlohmann-json3-dev
  python3
  # The Python client (client/python) and its tests, on Debian's interpreter.
  python3-zmq python3-protobuf python3-numpy python3-pytest python3-venv python3-pip
  python3-setuptools python3-wheel
  # The Debian package (scripts/package.sh): CPack reads the binaries' libraries with these.
  file dpkg-dev
)
for arg in "$@"; do
  case $arg in
    --plots) packages+=(python3-matplotlib python3-numpy python3-scipy) ;;
    --clang | --fuzz) packages+=(clang libclang-rt-14-dev) ;;
    *) echo "setup: unknown option '$arg' (--plots, --clang, --fuzz)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if ((${#missing[@]} == 0)); then
  echo "setup: all ${#packages[@]} packages already installed"
  exit 0
fi

sudo=""
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "setup: run as root or install sudo" >&2; exit 1; }
  sudo="sudo"
fi
echo "setup: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
