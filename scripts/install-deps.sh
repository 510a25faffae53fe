#!/usr/bin/env bash
# Installs every Debian package freeloc's build, tests and benchmarks need.
# Idempotent and non-interactive: packages already installed are skipped, and
# `apt-get update` runs at most once (only when something is missing).
set -euo pipefail

PACKAGES=(
  build-essential cmake make pkg-config ccache git
  libtorch-dev libopenblas0-openmp libopenblas-dev libdnnl-dev
  libeigen3-dev
  libopencv-dev libpng-dev libexif-dev
  libboost-dev libjs-three  # freeloc serve: the HTTP server (Boost.Beast, header-only), the page's 3D view
  libcpp-httplib-dev  # tests and bench/serve only: their HTTP client
  libnanoflann-dev
  nlohmann-json3-dev libcli11-dev libzip-dev zip unzip
  libgtest-dev libgmock-dev libbenchmark-dev
  pybind11-dev python3-dev python3-numpy python3-pytest
  python3-pil  # tests only: photos must decode as Pillow (the reference preprocessing) converts them
  libopenmpi-dev openmpi-bin
  chromium
  clang-format
)
# `make fuzz` also needs clang with libFuzzer and the sanitizer runtimes (not part of `make test`).
if [ "${FREELOC_DEPS_FUZZ:-0}" = 1 ]; then
  PACKAGES+=(clang libclang-rt-14-dev)
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

select_openblas_openmp() {
  # Debian's LibTorch calls the generic libblas.so.3 and libopenblas.so.0; point both (and LAPACK) at the OpenMP
  # build of OpenBLAS so GEMM runs at the machine's rate on the same OpenMP pool LibTorch uses (no
  # oversubscription). bench/gemm prints which BLAS is actually mapped.
  local arch dir
  arch="$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null || echo x86_64-linux-gnu)"
  dir="/usr/lib/$arch/openblas-openmp"
  [ -d "$dir" ] || return 0
  for lib in libblas.so.3 liblapack.so.3 libopenblas.so.0; do
    if [ -e "$dir/$lib" ] && [ "$(readlink -f "/usr/lib/$arch/$lib")" != "$(readlink -f "$dir/$lib")" ]; then
      $SUDO update-alternatives --set "$lib-$arch" "$dir/$lib" >/dev/null
      echo "install-deps: $lib -> $dir/$lib"
    fi
  done
}

SUDO=""
if [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1; then SUDO="sudo"; fi

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages already installed"
  select_openblas_openmp || true
  exit 0
fi

if [ "$(id -u)" -ne 0 ] && [ -z "$SUDO" ]; then
  echo "install-deps: not root and no sudo; install these packages: ${missing[*]}" >&2
  exit 1
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"

select_openblas_openmp || true
echo "install-deps: done"
