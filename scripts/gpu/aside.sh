#!/usr/bin/env bash
# Sets the tracked files a GPU call does not need aside, and puts them back
# (issue 53, item 1). A device call carries the working tree (tracked and
# untracked-not-ignored files) and the pack within 64 MiB; the tracked tree is
# about 50 MiB, of which the long runs' rescue points (7.5 MB each) and the
# pretrained policies (up to 4 MB each) are most, and nothing of scripts/gpu/
# reads them. So, here, before the calls:
#
#   scripts/gpu/aside.sh away [MIB]   # every rescue point (a path with a rescue/ folder)
#                                     # and every tracked file of MIB MiB or more
#                                     # (default 1) into .aside/, out of git's index
#   scripts/gpu/pack.sh ...           # measures the tree without them
#   (the device calls)
#   scripts/gpu/aside.sh back         # files and index entries as they were
#   scripts/gpu/aside.sh status       # what is aside, if anything
#
# Out of the index (`git rm --cached`) as well as out of the tree, so that the
# files are neither tracked nor untracked-not-ignored (.aside/ is ignored),
# whichever of the two a copy of the tree lists. .aside/MANIFEST holds each
# file's index entry (`git ls-files -s`: mode, blob, path), written before
# anything moves; `back` puts back each file still in .aside/ and each entry,
# so an `away` cut off halfway is undone by `back`. While files are aside,
# `scripts/long_runs.sh record` and `finish` refuse (they would write rescue
# points where `back` puts the old ones), and `away` refuses a second time.
# `back` refuses to overwrite a file that differs from the one set aside.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
cd "$repo"
aside=.aside
manifest=$aside/MANIFEST
die() { echo "aside.sh: $*" >&2; exit 1; }

away() {
  local mib=${1:-1} path n=0 bytes=0
  [[ $mib =~ ^[0-9]+$ ]] || die "MIB must be a whole number of MiB, not '$mib'"
  [ ! -e "$manifest" ] || die "files are aside already ($manifest): \`$0 back\` first"
  git check-ignore -q "$aside/x" || die "$aside/ is not ignored by git: it would travel (.gitignore)"
  local chosen=()
  while IFS= read -r -d '' path; do
    [ -f "$path" ] || continue
    if [[ /$path == */rescue/* ]] || [ "$(stat -c %s "$path")" -ge $((mib * 1048576)) ]; then
      chosen+=("$path")
    fi
  done < <(git ls-files -z)
  [ ${#chosen[@]} -gt 0 ] || { echo "nothing to set aside (no rescue point, no tracked file of $mib MiB or more)"; return; }
  mkdir -p "$aside/files"
  git ls-files -s -z -- "${chosen[@]}" > "$manifest.tmp"
  mv "$manifest.tmp" "$manifest"
  for path in "${chosen[@]}"; do
    bytes=$((bytes + $(stat -c %s "$path")))
    mkdir -p "$aside/files/$(dirname "$path")"
    mv "$path" "$aside/files/$path"
    n=$((n + 1))
  done
  git rm --cached -q -- "${chosen[@]}"
  echo "set aside $n files, $((bytes / 1048576)) MiB, into $aside/ (\`$0 back\` puts them back)"
  echo "the tree a call carries: $(($(travelling) / 1048576)) MiB"
}

# Bytes of what a copy of the tree carries: tracked and untracked-not-ignored files.
travelling() { git ls-files -z --cached --others --exclude-standard | xargs -0 -r du -cb 2> /dev/null | tail -n 1 | cut -f 1; }

back() {
  [ -f "$manifest" ] || die "nothing is aside (no $manifest)"
  local entry meta path n=0
  # First every conflict, so that a refusal moves nothing.
  while IFS= read -r -d '' entry; do
    path=${entry#*$'\t'}
    if [ -f "$aside/files/$path" ] && [ -e "$path" ] && ! cmp -s "$path" "$aside/files/$path"; then
      die "$path was written while it was aside: keep one (the aside one is $aside/files/$path), then \`$0 back\`"
    fi
  done < "$manifest"
  while IFS= read -r -d '' entry; do
    meta=${entry%%$'\t'*}
    path=${entry#*$'\t'}
    if [ -f "$aside/files/$path" ]; then
      if [ -e "$path" ]; then
        rm "$aside/files/$path"
      else
        mkdir -p "$(dirname "$path")"
        mv "$aside/files/$path" "$path"
      fi
    fi
    [ -f "$path" ] || die "$path is neither in the tree nor in $aside/files"
    # mode and blob as they were in the index (stage 0: an unmerged file is refused by `git rm --cached`)
    read -r mode blob _ <<< "$meta"
    git update-index --add --cacheinfo "$mode,$blob,$path"
    n=$((n + 1))
  done < "$manifest"
  rm "$manifest"
  rm -rf "$aside"
  echo "put back $n files"
}

status() {
  if [ -f "$manifest" ]; then
    echo "aside: $(tr -cd '\0' < "$manifest" | wc -c) files in $aside/ (\`$0 back\` puts them back)"
  else
    echo "nothing aside"
  fi
  echo "the tree a call carries: $(($(travelling) / 1048576)) MiB"
}

case "${1:-}" in
  away) shift; away "$@" ;;
  back) back ;;
  status) status ;;
  *) echo "usage: $0 away [MIB] | back | status" >&2; exit 2 ;;
esac
