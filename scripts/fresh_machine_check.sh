#!/usr/bin/env bash
# Proves the README's two commands on a fresh machine: makes a clean Debian 12
# (bookworm, minbase) root with mmdebstrap, copies a fresh clone of this
# checkout's HEAD into it, and runs the README's quick-start commands exactly
# as written there, inside the root (chroot), one after the other. Prints the
# time of each and the last lines of its output; exits non-zero naming the
# failing step. A developers' script (it takes 30-60 minutes), not part of CI.
#
# Usage: sudo bash scripts/fresh_machine_check.sh [--keep] [--workdir DIR]
#   --keep        leave the root (and its logs) in place for inspection
#   --workdir DIR where to make the root (default: a new folder under /var/tmp)
# Needs root (chroot, mounts) and Debian's package mirror; installs mmdebstrap
# on this machine if it is missing. Only committed work is checked (the clone
# is of HEAD).
set -euo pipefail

keep=0
workdir=""
while [ $# -gt 0 ]; do
  case "$1" in
    --keep) keep=1 ;;
    --workdir) workdir="${2:?--workdir needs a folder}"; shift ;;
    -h|--help) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "fresh_machine_check: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done

fail() { echo "fresh_machine_check: FAILED: $*" >&2; exit 1; }

[ "$(id -u)" -eq 0 ] || fail "needs root (mmdebstrap, chroot and bind mounts)"
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
readme="$repo/README.md"

# The README's commands, exactly as written: the first ```bash block, one
# command a line, trailing comments removed.
mapfile -t commands < <(awk '/^```bash/{inside=1; next} /^```/{if (inside) exit} inside' "$readme" |
  sed -e 's/[[:space:]]\{1,\}#.*$//' -e 's/[[:space:]]*$//' | grep -v '^[[:space:]]*$')
[ "${#commands[@]}" -eq 2 ] || fail "the README's first command block has ${#commands[@]} commands, expected exactly 2"

if ! command -v mmdebstrap >/dev/null; then
  echo "== installing mmdebstrap on this machine"
  apt-get -o DPkg::Lock::Timeout=900 update -qq
  DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=900 install -y -qq mmdebstrap >/dev/null
fi

if [ -z "$workdir" ]; then
  workdir="$(mktemp -d /var/tmp/quadhand-fresh.XXXXXX)"
else
  mkdir -p "$workdir"
fi
root="$workdir/root"
logs="$workdir/logs"
mkdir -p "$logs"

mounted=()
cleanup() {
  local i
  for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do
    umount -l "${mounted[$i]}" 2>/dev/null || true
  done
  # Never delete through a mount still in place: that would reach this
  # machine's own /dev, /proc or /sys.
  if grep -qF " $root/" /proc/mounts; then
    echo "fresh_machine_check: mounts remain under $root; not deleting $workdir" >&2
  elif [ "$keep" -eq 0 ]; then
    rm -rf "$workdir"
  else
    echo "fresh_machine_check: root and logs kept in $workdir"
  fi
}
trap cleanup EXIT

elapsed() { local s=$1; printf '%d min %02d s' $((s / 60)) $((s % 60)); }

echo "== making a clean Debian 12 root in $root (mmdebstrap --variant=minbase bookworm)"
t0=$SECONDS
mmdebstrap --variant=minbase bookworm "$root" >"$logs/mmdebstrap.log" 2>&1 ||
  { tail -n 20 "$logs/mmdebstrap.log" >&2; fail "mmdebstrap could not make the root"; }
root_time=$((SECONDS - t0))
echo "   done in $(elapsed "$root_time")"

# What every real installation has and a minbase root lacks: a hosts file
# (the UDP loopback tests resolve localhost). This machine's CA bundle goes to
# Node.js, whose registry access may pass through this workplace's TLS proxy.
printf '127.0.0.1 localhost\n::1 localhost ip6-localhost ip6-loopback\n' >"$root/etc/hosts"
cp /etc/resolv.conf "$root/etc/resolv.conf" 2>/dev/null || true
cp /etc/ssl/certs/ca-certificates.crt "$root/etc/host-ca-bundle.crt"

for fs in proc sys dev dev/pts; do
  mkdir -p "$root/$fs"
  mount --bind "/$fs" "$root/$fs"
  mounted+=("$root/$fs")
done

echo "== cloning $repo (HEAD $(git -C "$repo" rev-parse --short HEAD)) into the root"
git clone --quiet --no-local "$repo" "$root/root/quadhand" || fail "git clone"

step=0
times=()
for command in "${commands[@]}"; do
  step=$((step + 1))
  echo "== README command $step: $command"
  t0=$SECONDS
  if chroot "$root" /usr/bin/env -i HOME=/root TERM=dumb LANG=C.UTF-8 \
      PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
      NODE_EXTRA_CA_CERTS=/etc/host-ca-bundle.crt \
      bash -c "cd /root/quadhand && $command" >"$logs/command$step.log" 2>&1; then
    status=0
  else
    status=$?
  fi
  took=$((SECONDS - t0))
  times+=("$took")
  echo "   last lines of its output:"
  tail -n 15 "$logs/command$step.log" | sed 's/^/   | /'
  if [ "$status" -ne 0 ]; then
    keep=1
    fail "README command $step ('$command') exited $status after $(elapsed "$took"); full log: $logs/command$step.log"
  fi
  echo "   README command $step took $(elapsed "$took")"
done

echo
echo "fresh_machine_check: PASSED in a clean Debian 12 root"
echo "  root (mmdebstrap minbase):     $(elapsed "$root_time")"
for i in "${!commands[@]}"; do
  printf '  %-30s %s\n' "${commands[$i]}:" "$(elapsed "${times[$i]}")"
done
