#!/usr/bin/env bash
# The repository stays light to clone: every clone downloads all of its
# history, so a large file committed once weighs on every clone for good.
# Fails when HEAD's tree holds a file over 5 MiB, a file over 2 MiB outside
# pretrained/, or more than 56 million bytes in all (the stricter reading of
# 56 MiB, as the session checks count it).
#
#   scripts/check_tree_size.sh [REV]    # default HEAD
set -euo pipefail
rev=${1:-HEAD}
cd "$(dirname "$0")/.."
mib=$((1024 * 1024))
git ls-tree -r -l "$rev" | awk -v mib="$mib" '
  $2 == "blob" {
    size = $4; path = $5
    for (i = 6; i <= NF; i++) path = path " " $i
    total += size
    if (size > 5 * mib) { printf "check_tree_size: %s is %.2f MiB, over 5 MiB\n", path, size / mib; bad = 1 }
    else if (size > 2 * mib && path !~ /^pretrained\//) {
      printf "check_tree_size: %s is %.2f MiB, over 2 MiB outside pretrained/\n", path, size / mib; bad = 1
    }
  }
  END {
    printf "check_tree_size: the tree at '"$rev"' holds %.1f MB (at most 56)\n", total / 1e6
    if (total > 56e6) { print "check_tree_size: the tree is over 56 MB"; bad = 1 }
    exit bad
  }'
