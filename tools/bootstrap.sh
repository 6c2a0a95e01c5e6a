#!/usr/bin/env bash
# Installs the Debian 12 packages autocal needs (only those missing), builds, then either
# opens the workbench on the built-in simulated vest or runs every test.
#   tools/bootstrap.sh workbench [workbench args...]
#   tools/bootstrap.sh test      [ctest args...]
#   tools/bootstrap.sh build
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"

packages=(
  build-essential cmake ninja-build pkg-config ccache
  qtbase5-dev libqt5charts5-dev libqt5svg5-dev libqt5sql5-sqlite
  libopencv-dev libopencv-contrib-dev libeigen3-dev libceres-dev
  libvtk9-qt-dev libvtk9-dev
  libusb-1.0-0-dev libsqlite3-dev sqlite3
  libgtest-dev libgmock-dev libbenchmark-dev
  xvfb xauth umockdev libumockdev-dev
  opencv-doc
)

install_missing() {
  local missing=()
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  ((${#missing[@]} == 0)) && return 0
  echo "bootstrap: installing ${missing[*]}"
  local sudo=""
  [[ $(id -u) -ne 0 ]] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

build() {
  # Paths relative to the checkout let ccache reuse objects across clones (CI).
  export CCACHE_BASEDIR="$here" CCACHE_NOHASHDIR=true
  [[ -f build/CMakeCache.txt ]] || cmake --preset default
  cmake --build --preset default -j "$(nproc)"
}

mode="${1:-}"
shift || true
case "$mode" in
  workbench)
    install_missing
    build
    if [[ -z "${DISPLAY:-}" && -z "${WAYLAND_DISPLAY:-}" ]]; then
      # No desktop to open a window on: run it on a virtual display for a few seconds
      # and leave a screenshot, so a headless machine still shows that it works.
      shot="$here/build/workbench-screenshot.png"
      echo "bootstrap: no display; running the workbench under Xvfb for 8 s, screenshot -> $shot"
      exec xvfb-run -a -s "-screen 0 1600x1000x24" ./build/app/autocal-workbench \
        --screenshot "$shot" --quit-after 8000 "$@"
    fi
    exec ./build/app/autocal-workbench "$@"
    ;;
  test)
    install_missing
    build
    cd build
    exec xvfb-run -a -s "-screen 0 1600x1000x24" ctest --output-on-failure -j "$(nproc)" "$@"
    ;;
  build)
    install_missing
    build
    ;;
  *)
    echo "usage: tools/bootstrap.sh workbench|test|build [args...]" >&2
    exit 2
    ;;
esac
