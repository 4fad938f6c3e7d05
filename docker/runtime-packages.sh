#!/usr/bin/env bash
# Prints the Debian packages that own the shared libraries the given programs load, one per
# line, sorted: the runtime stage of docker/Dockerfile installs exactly these, so a new library
# dependency can never be forgotten in a hand-written list.
#
#   docker/runtime-packages.sh PROGRAM...
#
# ldd names a library by the path the loader found it at; with Debian's merged /usr that may be
# /lib/... while dpkg recorded /usr/lib/... (or the reverse), so both spellings and the resolved
# path are asked. A library no package owns is an error: the image would not start.
set -euo pipefail
owner() {
  local lib=$1 alt candidates
  case "$lib" in
    /usr/*) alt=${lib#/usr} ;;
    *) alt=/usr$lib ;;
  esac
  candidates=("$lib" "$alt" "$(readlink -f "$lib")")
  for path in "${candidates[@]}"; do
    if out=$(dpkg -S "$path" 2>/dev/null); then
      # "libfoo1:amd64: /usr/lib/..." -> libfoo1
      echo "${out%%:*}" | cut -d, -f1
      return 0
    fi
  done
  echo "runtime-packages: no Debian package owns $lib" >&2
  return 1
}
libs=$(ldd "$@" | awk '/=> \//{print $3} /^\s*\/lib/{print $1}' | sort -u)
packages=()
for lib in $libs; do
  packages+=("$(owner "$lib")")  # set -e: an unowned library ends the script here
done
printf '%s\n' "${packages[@]}" | sort -u
