#!/usr/bin/env bash
# Makes the Debian 12 base images the Dockerfile starts from when no registry is reachable:
# debootstrap from Debian's package mirror, then `podman import`. debian:bookworm (build stage,
# minbase plus what apt needs over https) and debian:bookworm-slim (runtime stage, minbase).
# Skips an image that exists. Root (debootstrap). Usage: docker/make-base.sh [MIRROR]
set -euo pipefail
MIRROR=${1:-http://deb.debian.org/debian}
ENGINE=${ENGINE:-podman}
work=$(mktemp -d /var/tmp/semmap-base.XXXXXX)
trap 'rm -rf "$work"' EXIT

make_base() {
  local tag=$1 include=$2 slim=${3:-}
  if $ENGINE image exists "$tag" 2>/dev/null; then
    echo "make-base: $tag exists"
    return
  fi
  echo "make-base: debootstrap bookworm for $tag (a few minutes)"
  local root="$work/${tag//[:\/]/_}"
  debootstrap --variant=minbase ${include:+--include="$include"} bookworm "$root" "$MIRROR" \
    >"$work/debootstrap.log" 2>&1 || { tail -n 20 "$work/debootstrap.log"; exit 1; }
  # What the official images carry: the security and updates suites, no caches.
  cat >"$root/etc/apt/sources.list" <<SOURCES
deb $MIRROR bookworm main
deb $MIRROR bookworm-updates main
deb http://deb.debian.org/debian-security bookworm-security main
SOURCES
  rm -rf "$root"/var/lib/apt/lists/* "$root"/var/cache/apt/*.bin "$root"/var/cache/apt/archives/*.deb
  if [ "$slim" = slim ]; then
    # As the official slim image: no manuals, translations or docs beyond the copyright files,
    # now and for every package installed later.
    cat >"$root/etc/dpkg/dpkg.cfg.d/slim" <<'DPKG'
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/man/*
path-exclude /usr/share/locale/*
path-exclude /usr/share/info/*
DPKG
    find "$root/usr/share/doc" -mindepth 2 ! -name copyright -delete 2>/dev/null || true
    rm -rf "$root"/usr/share/man/* "$root"/usr/share/locale/* "$root"/usr/share/info/*
  fi
  tar -C "$root" -c . | $ENGINE import --change 'CMD ["bash"]' - "$tag" >/dev/null
  echo "make-base: $tag imported ($(du -sh "$root" | cut -f1) unpacked)"
  rm -rf "$root"
}

make_base debian:bookworm-slim "" slim
make_base debian:bookworm "ca-certificates"
