#!/usr/bin/env bash
# Installs what gst-landmark needs on Debian 12 or 13 (system packages, the
# Python virtual environment) and builds it. Safe to run again: it only does what
# is missing. Sourced by scripts/demo.sh and scripts/test.sh.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
BUILD=${LANDMARK_BUILD_DIR:-$ROOT/build}
VENV=${LANDMARK_VENV:-$ROOT/.venv}

APT_PACKAGES=(
  ca-certificates meson ninja-build pkg-config g++ util-linux
  libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev libjson-glib-dev
  libmosquitto-dev
  libopencv-core-dev libopencv-imgproc-dev libopencv-calib3d-dev
  gstreamer1.0-tools gstreamer1.0-plugins-base gstreamer1.0-plugins-good
  gstreamer1.0-libav
  python3 python3-venv python3-gi python3-gst-1.0
  python3-aiohttp
  gir1.2-gstreamer-1.0 gir1.2-gst-plugins-base-1.0
)
# GStreamer >= 1.24 (Debian 13, Ubuntu 24.04): its analytics library, the
# stock overlay that draws it and its Python bindings (docs/metadata.md);
# Debian 12's 1.22 has none and builds without
os_release=$(. /etc/os-release 2>/dev/null; echo "${ID:-}:${VERSION_ID:-0}")
case "$os_release" in
  debian:1[3-9]* | debian:[2-9][0-9]* | ubuntu:2[4-9]* | ubuntu:[3-9][0-9]*)
    APT_PACKAGES+=(gstreamer1.0-plugins-bad libgstreamer-plugins-bad1.0-dev
      gir1.2-gst-plugins-bad-1.0) ;;
esac
# what only some commands need (the test command: valgrind, clang)
read -r -a extra_packages <<<"${LANDMARK_EXTRA_APT:-}"
APT_PACKAGES+=("${extra_packages[@]}")

log() { printf '[setup] %s\n' "$*" >&2; }

missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" -ne 0 ]; then
    log "missing Debian packages: ${missing[*]}"
    log "run as root, or: sudo apt-get install ${missing[*]}"
    exit 1
  fi
  log "installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt_log=$(mktemp)
  if ! { apt-get update -q && apt-get install -y -q --no-install-recommends "${missing[@]}"; } >"$apt_log" 2>&1; then
    tail -n 20 "$apt_log" >&2
    log "apt-get failed (full log: $apt_log)"
    exit 1
  fi
  rm -f "$apt_log"
fi

# Debian's python3 has the GStreamer bindings (gi); the venv sees them
# through --system-site-packages and adds numpy, OpenCV and pytest.
if [ ! -x "$VENV/bin/python" ]; then
  log "creating $VENV"
  /usr/bin/python3 -m venv --system-site-packages "$VENV"
fi
stamp="$VENV/.gstlandmark-installed"
if [ ! -f "$stamp" ] || [ "$ROOT/python/pyproject.toml" -nt "$stamp" ]; then
  log "installing the gstlandmark package into $VENV"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check -e "$ROOT/python[test]"
  touch "$stamp"
fi

export PATH="$VENV/bin:$PATH"
options=(-Dpython=enabled -Dtests=enabled "-Dtest_python=$VENV/bin/python")
if [ ! -f "$BUILD/build.ninja" ]; then
  log "configuring $BUILD"
  meson setup "$BUILD" "$ROOT" "${options[@]}" >/dev/null
else
  # --reconfigure also learns options added since the last set-up
  meson setup --reconfigure "$BUILD" "$ROOT" "${options[@]}" >/dev/null
fi
log "building"
ninja -C "$BUILD" >/dev/null

export GST_PLUGIN_PATH="$BUILD/plugins${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}"
