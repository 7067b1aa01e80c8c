#!/usr/bin/env bash
# Check for the Debian libraries lift-gl needs to render headless (EGL and OSMesa through
# Mesa's llvmpipe), the X server the viewer's test opens its window in (xvfb; xauth for
# xvfb-run) and the browser the notebook widget's test drives (chromium), and install the
# missing ones when running as root.
# Idempotent: when everything is present it only says so.
#   LIFT_GL_SKIP_SYSTEM=1  skip this check (e.g. a non-Debian machine set up by hand)
set -euo pipefail

PACKAGES=(libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6 xvfb xauth chromium)

if [[ "${LIFT_GL_SKIP_SYSTEM:-0}" == "1" ]]; then
    echo "setup_system: skipped (LIFT_GL_SKIP_SYSTEM=1)"
    exit 0
fi

if ! command -v dpkg-query >/dev/null 2>&1; then
    echo "setup_system: warning: no dpkg here (not Debian/Ubuntu); cannot check for" >&2
    echo "  the headless GL libraries. Install your system's equivalents of:" >&2
    echo "  ${PACKAGES[*]} (libEGL with Mesa, Mesa DRI drivers, OSMesa, the Xvfb X server)." >&2
    exit 0
fi

missing=()
for pkg in "${PACKAGES[@]}"; do
    status=$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null || true)
    if [[ "$status" != "install ok installed" ]]; then
        missing+=("$pkg")
    fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
    echo "setup_system: headless GL libraries and Xvfb present (${PACKAGES[*]})"
    exit 0
fi

if [[ "$(id -u)" -ne 0 ]]; then
    echo "setup_system: missing Debian packages: ${missing[*]}" >&2
    echo "  lift-gl needs them to render without a display (and to test its viewer). Install them with:" >&2
    echo "    sudo apt-get update && sudo apt-get install -y ${missing[*]}" >&2
    echo "  (or set LIFT_GL_SKIP_SYSTEM=1 to skip this check)" >&2
    exit 1
fi

echo "setup_system: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update
apt-get install -y --no-install-recommends "${missing[@]}"
