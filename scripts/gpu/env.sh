# Sourced by the steps that run on the GPU machine (start.sh, finish.sh): the
# packed binaries (unpacked from bin.tar.xz on first use), model, Vulkan loader and MuJoCo library of scripts/gpu/pack.sh.
# Needs root for the loader (the .debs are unpacked into /).
pack=${FMSR_PACK:-.gpu}
if [ -f "$pack/bin.tar.xz" ] && [ ! -x "$pack/bin/fmsr" ]; then
  mkdir -p "$pack/bin"
  xz -dc "$pack/bin.tar.xz" | tar xf - -C "$pack/bin"
fi
if [ ! -x "$pack/bin/fmsr" ]; then
  echo "no $pack/bin/fmsr: run scripts/gpu/pack.sh where there is network, and carry $pack" >&2
  exit 2
fi
# The loader and glvnd (NVIDIA's Vulkan driver needs libGLdispatch), when
# either is missing.
if [ -d "$pack/debs" ] && ! { ldconfig -p | grep -q libvulkan.so.1 && ldconfig -p | grep -q libGLdispatch.so.0; }; then
  for f in "$pack"/debs/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -f "$icd" ] && [ -z "${VK_DRIVER_FILES:-}" ]; then
  export VK_DRIVER_FILES=$icd
fi
if [ -d "$pack/lib" ]; then
  export LD_LIBRARY_PATH=$PWD/$pack/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
fi
export FMSR_ASSETS_DIR=$PWD/$pack/assets
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
  XDG_RUNTIME_DIR=$(mktemp -d)
  export XDG_RUNTIME_DIR
fi
FMSR=$pack/bin/fmsr
