#!/usr/bin/env bash
# Installs every Debian 12 package semmap needs to build, test and run.
# Idempotent: when everything is present it only runs dpkg-query and exits.
# `install-deps.sh fuzz` adds clang with its sanitizer runtimes and libFuzzer (make test-asan,
# test-tsan, fuzz).
# `install-deps.sh train` adds PyTorch (CPU), OpenCV for Python, pytest and matplotlib for training/
# (make train-vo, make train-smoke).
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build ccache pkg-config clang-format git
  # RPC
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  # vision / geometry / maps
  libopencv-dev libeigen3-dev libceres-dev liboctomap-dev libpcl-dev
  # storage, hashing, json
  libsqlite3-dev libssl-dev nlohmann-json3-dev
  # semmapd's allocator (glibc malloc's arena locks stall gRPC's threads under load)
  libjemalloc-dev
  # logging (levels, one logger for the tree)
  libspdlog-dev
  # image decoding (PNG, JPEG; libdeflate inflates PNGs on the fast path)
  libpng-dev libjpeg-dev zlib1g-dev libdeflate-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # scripts: process control, JSON in bench scripts
  procps jq
  # TLS tests make their keys and certificates with the openssl tool
  openssl
  # the Python client (client/python) and its tests
  python3-grpcio python3-protobuf python3-numpy python3-opencv python3-pytest
)
for extra in "$@"; do
  case "$extra" in
    fuzz) PACKAGES+=(clang libclang-rt-14-dev) ;;  # libFuzzer, ASan/UBSan/TSan runtimes
    lint) PACKAGES+=(clang-tidy) ;;
    train) PACKAGES+=(python3-torch python3-numpy python3-opencv python3-pytest python3-matplotlib) ;;  # training/ (learned VO)
    *) echo "install-deps: unknown package set '$extra' (known: fuzz, lint, train)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "install-deps: need root or sudo to install: ${missing[*]}" >&2
    exit 1
  fi
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install-deps: done"
