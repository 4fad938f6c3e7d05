#!/usr/bin/env bash
# Makes the image `debian:bookworm-slim` locally with debootstrap, for hosts that reach Debian's
# mirror but no container registry (this CI machine). Where a registry is reachable, `docker pull
# debian:bookworm-slim` gives the official image and this script is not needed.
#
#   docker/make-base-image.sh [TAG]        (default TAG debian:bookworm-slim; needs root)
#
# Slimmed like the official -slim images (debuerreotype's "slimify"): dpkg excludes for
# documentation, man pages and locales, so packages installed later stay small too; no apt
# caches or lists. Skips the work when the tag exists already.
set -euo pipefail
TAG=${1:-debian:bookworm-slim}
MIRROR=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
if docker image inspect "$TAG" >/dev/null 2>&1; then
  echo "make-base-image: $TAG present"
  exit 0
fi
root=$(mktemp -d /tmp/drivegw-rootfs.XXXXXX)
trap 'rm -rf "$root"' EXIT
echo "make-base-image: debootstrap --variant=minbase bookworm from $MIRROR"
debootstrap --variant=minbase bookworm "$root" "$MIRROR" >"$root.log" 2>&1 ||
  { tail -20 "$root.log" >&2; exit 1; }
rm -f "$root.log"
cat >"$root/etc/dpkg/dpkg.cfg.d/docker-slim" <<'CFG'
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/man/*
path-exclude /usr/share/info/*
path-exclude /usr/share/locale/*
path-exclude /usr/share/groff/*
path-exclude /usr/share/lintian/*
path-exclude /usr/share/linda/*
CFG
# Apply the same excludes to what debootstrap already unpacked.
find "$root/usr/share/doc" -mindepth 1 -not -name copyright -not -type d -delete
find "$root/usr/share/doc" -mindepth 1 -type d -empty -delete
rm -rf "$root"/usr/share/{man,info,locale,groff,lintian,linda}/*
rm -rf "$root"/var/cache/apt/archives/*.deb "$root"/var/lib/apt/lists/* "$root"/var/log/*.log
# The official images' apt settings: no caches kept inside a layer.
cat >"$root/etc/apt/apt.conf.d/docker-clean" <<'CFG'
DPkg::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
APT::Update::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
Dir::Cache::pkgcache ""; Dir::Cache::srcpkgcache "";
CFG
echo 'Acquire::Languages "none";' >"$root/etc/apt/apt.conf.d/docker-no-languages"
tar -C "$root" -c . | docker import --change 'CMD ["bash"]' - "$TAG" >/dev/null
echo "make-base-image: $TAG $(docker image inspect -f '{{.Size}}' "$TAG" | awk '{printf "%.0f MB", $1/1e6}')"
