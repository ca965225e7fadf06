#!/usr/bin/env bash
# Installs Mesa's CPU Vulkan driver (lavapipe) and the Vulkan loader, so that a
# `--features wgpu` build can run the GPU code path on the CPU (device
# "wgpu:cpu"), as CI does (docs/design.md, "Devices").
#
#   scripts/setup_lavapipe.sh
#   export XDG_RUNTIME_DIR=$(mktemp -d)   # wgpu warns on every call without one
#   cargo test --features wgpu --test gpu
#
# Idempotent: installs nothing when the loader and lavapipe's ICD are present.
# Needs root (or sudo) for apt-get.
set -euo pipefail
have_lavapipe() { ls /usr/share/vulkan/icd.d/lvp_icd.*.json >/dev/null 2>&1 && ldconfig -p | grep -q libvulkan.so.1; }
if have_lavapipe; then
  echo "lavapipe already installed: $(ls /usr/share/vulkan/icd.d/lvp_icd.*.json)"
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update
$SUDO apt-get install -y --no-install-recommends mesa-vulkan-drivers libvulkan1
echo "installed: $(ls /usr/share/vulkan/icd.d/lvp_icd.*.json)"
