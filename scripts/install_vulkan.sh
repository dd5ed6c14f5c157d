#!/usr/bin/env bash
# Make sure SAPIEN can find a Vulkan device. A GPU's own driver wins; on a CPU-only
# Debian/Ubuntu machine we install Mesa's lavapipe (software Vulkan), which SAPIEN
# accepts only from Mesa 23 on. Debian 12 ships 22.3, so there we take the package
# from bookworm-backports, reusing the host of the machine's own Debian source entry.
set -euo pipefail

SUDO=""
if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi

mesa_major() {
  local v
  v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
  [ -n "$v" ] || { echo 0; return; }
  echo "${v%%.*}" | sed 's/^[0-9]*://'
}

has_gpu_icd() {
  # Any ICD that is not Mesa's software rasteriser counts as a real device.
  ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json 2>/dev/null \
    | grep -v -e lvp_icd -e intel -e radeon -e virtio -e freedreno -e broadcom -e panfrost -e asahi -e nouveau -e gfxstream \
    | grep -q .
}

if has_gpu_icd; then
  echo "[vulkan] a GPU Vulkan driver is present; nothing to install"
  exit 0
fi
if [ "$(mesa_major)" -ge 23 ] && dpkg-query -W libvulkan1 >/dev/null 2>&1; then
  echo "[vulkan] Mesa $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers) lavapipe already installed"
  exit 0
fi

. /etc/os-release
codename="${VERSION_CODENAME:-}"
if [ "${ID:-}" = "debian" ] && [ "$codename" = "bookworm" ]; then
  uri=""
  for f in /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] || continue
    uri=$(awk '/^URIs:/ {for (i=2;i<=NF;i++) if ($i !~ /security/) {print $i; exit}}' "$f")
    [ -n "$uri" ] && break
  done
  if [ -z "$uri" ] && [ -f /etc/apt/sources.list ]; then
    uri=$(awk '/^deb / && $0 !~ /security/ {print $2; exit}' /etc/apt/sources.list)
  fi
  [ -n "$uri" ] || { echo "[vulkan] no Debian apt source found to derive bookworm-backports from" >&2; exit 1; }
  echo "deb $uri bookworm-backports main" | $SUDO tee /etc/apt/sources.list.d/xicm-bookworm-backports.list >/dev/null
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq -t bookworm-backports mesa-vulkan-drivers libvulkan1 >/dev/null
else
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
fi
echo "[vulkan] installed Mesa $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers)"
if [ "$(mesa_major)" -lt 23 ]; then
  echo "[vulkan] Mesa is older than 23; SAPIEN will not render on the CPU here" >&2
  exit 1
fi
