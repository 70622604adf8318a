#!/usr/bin/env bash
# Builds polyport's .deb (cpack -G DEB) from a build folder and installs it into a clean
# Debian 12 root made by debootstrap (minbase, Debian's own mirror from this machine's apt
# sources), with apt-get inside the chroot fetching its dependencies from Debian; then runs
# `polyportd --version`, `polyportd check` and a one-second `polyportd run` of the shipped
# wheelchair profile there.
# The bare root is cached as BUILD/debian12-minbase.tar.gz, so a second run skips
# debootstrap. Needs root (chroot, mounts) and network to the mirror.
#   scripts/test_deb.sh [BUILD_DIR]     (default: build)
set -euo pipefail
build=$(realpath "${1:-$(dirname "$0")/../build}")
fail() { echo "FAIL: $*" >&2; exit 1; }
[ "$(id -u)" -eq 0 ] || fail "test_deb.sh needs root (debootstrap, chroot and mounting /proc); run it as root or with sudo"
for tool in cpack debootstrap chroot; do
  command -v "$tool" >/dev/null || fail "$tool not found (scripts/setup.sh installs debootstrap)"
done
[ -f "$build/CPackConfig.cmake" ] || fail "$build is not a configured build folder (scripts/build.sh)"
t0=$(date +%s)

# The Debian mirror this machine's apt uses (one-line or deb822 sources).
mirror=$(cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list /etc/apt/sources.list.d/*.sources 2>/dev/null |
  awk '/^deb / && $2 !~ /security/ && !found {print $2; found = 1}
       /^URIs:/ && $2 !~ /security/ && !found {print $2; found = 1}' | sed 's#/*$##' || true)
[ -n "$mirror" ] || mirror=http://deb.debian.org/debian
security=${mirror%/debian}/debian-security

echo "== cpack -G DEB"
rm -rf "$build/deb"
cpack -G DEB --config "$build/CPackConfig.cmake" -B "$build/deb" >"$build/deb.log" 2>&1 || { cat "$build/deb.log"; fail "cpack"; }
deb=$(ls "$build"/deb/polyport_*.deb)
dpkg-deb --field "$deb" Package Version Depends

cache=$build/debian12-minbase.tar.gz
if [ ! -f "$cache" ]; then
  echo "== debootstrap --variant=minbase bookworm from $mirror (cached as $cache)"
  fresh=$(mktemp -d "$build/debootstrap.XXXXXX")
  debootstrap --variant=minbase bookworm "$fresh" "$mirror" >"$build/debootstrap.log" 2>&1 ||
    { tail -20 "$build/debootstrap.log"; rm -rf "$fresh"; fail "debootstrap"; }
  tar -C "$fresh" -czf "$cache.part" . && mv "$cache.part" "$cache"
  rm -rf "$fresh"
fi

root=$(mktemp -d /tmp/polyport-deb-root.XXXXXX)
cleanup() {
  mountpoint -q "$root/proc" && umount "$root/proc"
  rm -rf "$root"
}
trap cleanup EXIT
tar -C "$root" -xzf "$cache"
mount -t proc proc "$root/proc"
cp /etc/resolv.conf "$root/etc/resolv.conf"
cat >"$root/etc/apt/sources.list" <<SOURCES
deb $mirror bookworm main
deb $mirror bookworm-updates main
deb $security bookworm-security main
SOURCES
cp "$deb" "$root/tmp/"
in_root() { chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin DEBIAN_FRONTEND=noninteractive "$@"; }

echo "== apt-get install ./$(basename "$deb") in the Debian 12 root"
in_root apt-get update -qq >"$build/deb-apt.log" 2>&1 || { cat "$build/deb-apt.log"; fail "apt-get update in the root"; }
in_root apt-get install -y -q --no-install-recommends "/tmp/$(basename "$deb")" >>"$build/deb-apt.log" 2>&1 ||
  { tail -30 "$build/deb-apt.log"; fail "apt-get install of the .deb in the root"; }
grep -E '^(Setting up|Unpacking) ' "$build/deb-apt.log" | wc -l | xargs echo "packages set up:"

echo "== polyportd in the root"
in_root polyportd --version || fail "polyportd --version in the root"
in_root polyportd check /usr/share/polyport/profiles/wheelchair_inproc.xml >"$build/deb-check.log" 2>&1 ||
  { cat "$build/deb-check.log"; fail "polyportd check in the root"; }
head -5 "$build/deb-check.log"
# The installed plugin loads and runs from /usr/lib/polyport.
in_root polyportd run /usr/share/polyport/profiles/wheelchair_inproc.xml --duration 1 --admin-socket none -q \
  --stats-json /tmp/stats.json >"$build/deb-run.log" 2>&1 || { cat "$build/deb-run.log"; fail "polyportd run in the root"; }
grep -q '"executions"' "$root/tmp/stats.json" || fail "no statistics from the run in the root"
in_root polyportctl --help >/dev/null || fail "polyportctl --help in the root"
echo "ok: the .deb installs in a clean Debian 12 root and polyportd runs ($(( $(date +%s) - t0 )) s)"
