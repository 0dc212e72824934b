#!/usr/bin/env bash
# Proves the README's two commands on a truly fresh Debian: a minimal bookworm root (debootstrap
# --variant=minbase: no compiler, no make, no Python), a clean clone of this repository's committed
# HEAD copied in, and `bash scripts/run.sh` then `bash scripts/test.sh` run inside it as root.
# Prints each command's time and status and, for a failure, the end of its log; exits non-zero when
# either command fails. Run it after any change to set-up, packages or install steps (about 70 minutes
# on 2 cores; it is not part of CI).
#
# Only the pristine root is cached, as a tarball (default /var/cache/dem-fresh-root); every run unpacks
# a new copy into a scratch folder, so nothing one run installs is seen by the next. Mounts live in a
# private mount namespace and vanish with it. Needs root, Debian's debootstrap (installed if missing)
# and Debian's mirror.
#   bash scripts/fresh_root.sh [--keep] [--only run|test] [--refresh]
#     --keep      keep the scratch root (its logs are in <root>/root/dem-logs)
#     --only      run one of the two commands
#     --refresh   build the pristine root anew
#   DEM_FRESH_CACHE (cache folder), DEM_FRESH_WORK (scratch parent, default /tmp),
#   DEM_FRESH_MIRROR (default http://deb.debian.org/debian)
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)

keep=0
only=""
refresh=0
while [ $# -gt 0 ]; do
  case $1 in
    --keep) keep=1 ;;
    --only) only=${2:?--only needs run or test}; shift ;;
    --refresh) refresh=1 ;;
    *) echo "usage: scripts/fresh_root.sh [--keep] [--only run|test] [--refresh]" >&2; exit 2 ;;
  esac
  shift
done
case $only in "" | run | test) ;; *) echo "fresh_root: --only takes run or test, not '$only'" >&2; exit 2 ;; esac
[ "$(id -u)" -eq 0 ] || { echo "fresh_root: run as root (debootstrap, chroot and mounts need it)" >&2; exit 2; }

cache=${DEM_FRESH_CACHE:-/var/cache/dem-fresh-root}
mirror=${DEM_FRESH_MIRROR:-http://deb.debian.org/debian}
tarball=$cache/bookworm-minbase.tar.gz

# The pristine root: made once, stored as a tarball.
if [ "$refresh" -eq 1 ] || [ ! -f "$tarball" ]; then
  bash scripts/install_deps.sh debootstrap
  mkdir -p "$cache"
  staging=$(mktemp -d "$cache/staging.XXXXXX")
  echo "fresh_root: debootstrap --variant=minbase bookworm from $mirror"
  if ! debootstrap --variant=minbase bookworm "$staging" "$mirror" > "$cache/debootstrap.log" 2>&1; then
    tail -n 30 "$cache/debootstrap.log" >&2
    rm -rf "$staging"
    echo "fresh_root: debootstrap failed (log: $cache/debootstrap.log)" >&2
    exit 1
  fi
  # What a bookworm installation lists: the release, its updates and its security archive.
  cat > "$staging/etc/apt/sources.list" <<EOF
deb $mirror bookworm main
deb $mirror bookworm-updates main
deb http://deb.debian.org/debian-security bookworm-security main
EOF
  tar -C "$staging" -czf "$tarball.tmp" .
  mv "$tarball.tmp" "$tarball"
  rm -rf "$staging"
fi

# A new copy of the pristine root and a clean clone of the committed HEAD inside it.
work=$(mktemp -d "${DEM_FRESH_WORK:-/tmp}/dem-fresh-root.XXXXXX")
root=$work/root
cleanup() {
  if [ "$keep" -eq 1 ]; then echo "fresh_root: kept $root"; else rm -rf "$work"; fi
}
trap cleanup EXIT
mkdir -p "$root"
tar -C "$root" -xzf "$tarball"
if ! git diff --quiet HEAD || [ -n "$(git status --porcelain --untracked-files=normal)" ]; then
  echo "fresh_root: note: uncommitted changes are not tested (the clone holds HEAD)"
fi
commit=$(git rev-parse --short HEAD)
git clone -q --no-local --no-hardlinks "$repo" "$root/root/dem"
cp /etc/resolv.conf "$root/etc/resolv.conf"
mkdir -p "$root/root/dem-logs"

# One README command inside the root, in a private mount namespace; returns its status.
in_root() {  # <name> <command>
  local name=$1 command=$2
  local log=$root/root/dem-logs/$name.log
  local start=$SECONDS status=0
  echo "fresh_root: $name: bash $command"
  unshare --mount --propagation private sh -c '
    set -e
    root=$1
    mount -t proc proc "$root/proc"
    mount -t sysfs sys "$root/sys"
    mount --rbind /dev "$root/dev"
    mount -t tmpfs tmpfs "$root/dev/shm"
    exec chroot "$root" /usr/bin/env -i HOME=/root TERM=dumb LANG=C.UTF-8 \
      PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
      bash -c "cd /root/dem && bash $2"
  ' fresh_root "$root" "$command" > "$log" 2>&1 || status=$?
  echo "fresh_root: $name: $([ "$status" -eq 0 ] && echo ok || echo "FAILED (exit $status)") in $((SECONDS - start)) s"
  if [ "$status" -ne 0 ]; then
    echo "---- last 60 lines of $name.log ----"
    tail -n 60 "$log"
    echo "----"
  fi
  return "$status"
}

failed=()
if [ -z "$only" ] || [ "$only" = run ]; then
  in_root run scripts/run.sh || failed+=(run)
fi
if [ -z "$only" ] || [ "$only" = test ]; then
  in_root test scripts/test.sh || failed+=(test)
fi
# The test log's stage times and ctest's summary, for the closing note.
if [ -f "$root/root/dem-logs/test.log" ]; then
  grep -E '^== |tests passed|tests failed|Disabled|\*\*\*(Failed|Timeout|Exception)' "$root/root/dem-logs/test.log" || true
fi
if [ ${#failed[@]} -gt 0 ]; then
  echo "fresh_root: FAILED: ${failed[*]} (on $commit; rerun with --keep to inspect)"
  exit 1
fi
echo "fresh_root: both README commands passed in a fresh bookworm root on $commit"
