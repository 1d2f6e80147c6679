#!/usr/bin/env bash
# Debian packages BRDF Studio needs beyond Python: a virtual X server and the xcb/GL libraries Qt and VTK load.
# libegl-mesa0 (Mesa's EGL) and libgl1-mesa-dri (its llvmpipe driver) give check-models' shader oracle a
# headless software OpenGL context. libllvm19 lets Mitsuba 3 (test and benchmark reference) run its llvm variants.
# Installs what is missing when run as root; otherwise prints the exact command to run.
set -euo pipefail

PKGS=(
  xvfb xauth
  libxcb-cursor0 libxcb-icccm4 libxcb-keysyms1 libxcb-image0 libxcb-render-util0 libxcb-randr0
  libxcb-shape0 libxcb-xinerama0 libxcb-xkb1 libxkbcommon-x11-0 libxkbcommon0
  libgl1 libegl1 libegl-mesa0 libglx-mesa0 libgl1-mesa-dri libglib2.0-0 libfontconfig1 libdbus-1-3
  libxrender1 libxi6 libxext6 libsm6 libice6
  libllvm19
)

missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "system packages: all present"
  exit 0
fi

cmd="apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends ${missing[*]}"
if [ "$(id -u)" -eq 0 ]; then
  echo "system packages: installing ${missing[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "system packages missing: ${missing[*]}" >&2
  echo "run as root:  $cmd" >&2
  exit 1
fi
