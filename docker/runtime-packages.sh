#!/usr/bin/env bash
# Prints the Debian packages that hold the shared libraries the given executables load (ldd,
# then dpkg -S): the runtime stage installs exactly these, never a -dev package.
set -euo pipefail
for binary in "$@"; do
  ldd "$binary" | awk '/=> \// {print $3}'
done | sort -u | while read -r lib; do
  real=$(readlink -f "$lib")
  # Debian 12 is usr-merged: dpkg knows a library under /usr/lib or /lib, whichever it shipped.
  for candidate in "$lib" "$real" "${lib#/usr}" "/usr${lib}" "${real#/usr}" "/usr${real}"; do
    if owner=$(dpkg -S "$candidate" 2>/dev/null); then
      echo "${owner%%:*}"
      break
    fi
  done
done | sed 's/, /\n/g' | sort -u | grep -v -- '-dev$'
