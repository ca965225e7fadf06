#!/usr/bin/env bash
# scripts/check_tree_size.sh fails on what it says, on a scratch repository:
# a file over 5 MiB, one over 2 MiB outside pretrained/, a tree over 56 MiB;
# and passes a tree within its limits.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
cd "$scratch"
git init -q . && git config user.email t@t && git config user.name t
mkdir -p scripts pretrained/p docs
cp "$repo/scripts/check_tree_size.sh" scripts/
mb() { head -c $(($2 * 1024 * 1024)) /dev/urandom > "$1"; }
commit() { git add -A && git commit -qm "$1"; }
mb pretrained/p/a.fmsr 4 && mb docs/small.png 1 && commit ok
scripts/check_tree_size.sh > /dev/null || { echo "FAILED: a tree within its limits was refused"; exit 1; }
mb docs/big.gif 3 && commit outside
! scripts/check_tree_size.sh > /dev/null || { echo "FAILED: 3 MiB outside pretrained/ passed"; exit 1; }
git rm -q docs/big.gif && mb pretrained/p/huge.fmsr 6 && commit huge
! scripts/check_tree_size.sh > /dev/null || { echo "FAILED: a 6 MiB file passed"; exit 1; }
git rm -q pretrained/p/huge.fmsr && for i in $(seq 1 12); do mb "pretrained/p/f$i.fmsr" 5; done && commit total
! scripts/check_tree_size.sh > /dev/null || { echo "FAILED: a 65 MiB tree passed"; exit 1; }
echo "ok: check_tree_size refuses files over 5 MiB, over 2 MiB outside pretrained/, and trees over 56 MB"
