# shellcheck shell=bash
# Sourced by the steps that run on the GPU machine (start.sh, finish.sh): the
# packed binaries (unpacked from bin.tar.xz, or its parts, on first use), model, Vulkan loader and MuJoCo library of scripts/gpu/pack.sh.
# Needs root for the loader (the .debs are unpacked into /).
pack=${FMSR_PACK:-.gpu}
parts=$(sed -n 's/^parts //p' "$pack/MANIFEST" 2>/dev/null || true)
if [ ! -x "$pack/bin/fmsr" ] && [ -f "$pack/bin.tar.xz" ]; then
  mkdir -p "$pack/bin"
  xz -dc "$pack/bin.tar.xz" | tar xf - -C "$pack/bin"
elif [ ! -x "$pack/bin/fmsr" ] && [ -n "$parts" ]; then
  # The archive in parts, part N in "$pack-N", each carried by a call of its own.
  files=()
  for i in $(seq 1 "$parts"); do
    dir=$pack
    [ "$i" -gt 1 ] && dir=$pack-$i
    if [ ! -f "$dir/bin.tar.xz.part$i" ]; then
      echo "$dir/bin.tar.xz.part$i has not come: carry $dir in a call of its own (the binaries travel in $parts parts)" >&2
      exit 2
    fi
    files+=("$dir/bin.tar.xz.part$i")
  done
  mkdir -p "$pack/bin"
  cat "${files[@]}" | xz -dc | tar xf - -C "$pack/bin"
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
# libnvrtc for the `cuda-nvrtc` build, which opens it at run time: the
# machine's CUDA toolkit (2026-11-27, an H200 lease: /usr/local/cuda/lib64).
if [ -d /usr/local/cuda/lib64 ]; then
  export LD_LIBRARY_PATH=${LD_LIBRARY_PATH:+$LD_LIBRARY_PATH:}/usr/local/cuda/lib64
fi
# The model: this pack's, else the one another pack brought to this machine
# in an earlier call (pack.sh --no-assets; FMSR_ASSETS_DIR names it).
if [ -d "$pack/assets" ]; then
  export FMSR_ASSETS_DIR=$PWD/$pack/assets
fi
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
  XDG_RUNTIME_DIR=$(mktemp -d)
  export XDG_RUNTIME_DIR
fi
# cubecl's autotune results of an earlier lease (pack.sh packs them), where
# this machine has none yet: cubecl reads them from target/environment, the
# repository's, as the scripts here run from its root.
if [ -f "$pack/cubecl_cache.tar.gz" ] && [ ! -d target/environment ]; then
  mkdir -p target
  tar xzf "$pack/cubecl_cache.tar.gz" -C target
fi
export FMSR=$pack/bin/fmsr
