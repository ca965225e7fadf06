#!/usr/bin/env bash
# Fetches MuJoCo 3.17.0 (the shared library of the PyPI wheel `mujoco==3.17.0`)
# into <repo>/target/mujoco/lib for the `mujoco` feature of fmsr-envs (docs/design.md 4).
#
#   scripts/setup_mujoco.sh            # then: cargo test --workspace --features mujoco
#
# Idempotent: does nothing when target/mujoco/lib/libmujoco.so.3.17.0 exists.
# The build finds the library through MUJOCO_DYNAMIC_LINK_DIR, which
# .cargo/config.toml sets to target/mujoco/lib (an exported value wins). At run
# time `cargo run/test/bench` put that directory on the loader path themselves (it
# lies inside the target directory), and fmsr-envs' own tests carry an rpath to it.
# To run a built binary directly: LD_LIBRARY_PATH=<repo>/target/mujoco/lib.
set -euo pipefail
cd "$(dirname "$0")/.."
VERSION=3.17.0
DEST="$PWD/target/mujoco"
LIB="$DEST/lib"
if [ -f "$LIB/libmujoco.so.$VERSION" ] && [ -L "$LIB/libmujoco.so" ]; then
  echo "MuJoCo $VERSION already in $LIB"
  exit 0
fi
mkdir -p "$DEST/wheel" "$LIB"
# The manylinux x86_64 wheel for this Python (pip picks the tag).
python3 -m pip download --disable-pip-version-check --no-deps --only-binary=:all: \
  "mujoco==$VERSION" -d "$DEST/wheel"
WHEEL=$(ls "$DEST"/wheel/mujoco-"$VERSION"-*.whl | head -n 1)
python3 - "$WHEEL" "$LIB" "$VERSION" <<'PY'
import os, sys, zipfile
wheel, lib, version = sys.argv[1:4]
name = f"mujoco/libmujoco.so.{version}"
with zipfile.ZipFile(wheel) as z:
    data = z.read(name)
tmp = os.path.join(lib, f".libmujoco.so.{version}.tmp{os.getpid()}")
with open(tmp, "wb") as f:
    f.write(data)
os.chmod(tmp, 0o755)
os.replace(tmp, os.path.join(lib, f"libmujoco.so.{version}"))
PY
# mujoco-rs links `-lmujoco`; the library's soname is libmujoco.so.$VERSION.
ln -sfn "libmujoco.so.$VERSION" "$LIB/libmujoco.so"
echo "MuJoCo $VERSION in $LIB"
