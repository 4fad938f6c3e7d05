#!/usr/bin/env bash
# Proves drivegw's SocketCAN code on a real Linux kernel: boots Debian's kernel in qemu (TCG) from a
# busybox initramfs, loads can, can-raw, can-dev and vcan, creates vcan0 and runs test binaries
# there. The host kernel (and CI's) has no CAN at all. Details and knobs: README.md in this folder.
#   tests/socketcan-vm/run.sh BUILD_DIR [TEST...]
# TEST: a path to an executable (gtest or plain), or can_raw_smoke. Without TESTs: every line of
# vm-tests.list plus every executable under BUILD_DIR/tests named *socketcan* or *vcan*.
# Exit 0 only if every test ran and passed in the VM; the last line is always
# "socketcan-vm: N passed, M failed".
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
CACHE=${DGW_VM_CACHE:-${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/drivegw/socketcan-vm}
VM_TIMEOUT=${DGW_VM_TIMEOUT:-180}          # hard limit for the whole VM run (host side), seconds
TEST_TIMEOUT=${DGW_VM_TEST_TIMEOUT:-60}    # per test inside the VM, seconds
MEM=${DGW_VM_MEM:-512}                     # MiB; the unpacked initramfs lives in it
MODULES=${DGW_VM_MODULES:-can can-raw can-dev vcan}
LIST=${DGW_VM_LIST:-$HERE/vm-tests.list}
QEMU=${DGW_VM_QEMU:-qemu-system-x86_64}
T_START=$EPOCHREALTIME

PLANNED=0
CLOSED=""
TMPDIRS=()
say() { echo "socketcan-vm: $*"; }
die() { echo "socketcan-vm: error: $*" >&2; exit 2; }
on_exit() {
  local rc=$?
  [ ${#TMPDIRS[@]} -eq 0 ] || rm -rf "${TMPDIRS[@]}"
  if [ -z "$CLOSED" ]; then
    local n=$PLANNED
    [ "$n" -gt 0 ] || n=1
    echo "socketcan-vm: 0 passed, $n failed (stage did not complete, exit $rc; see above)"
  fi
}
trap on_exit EXIT
secs_since() { awk -v a="$1" -v b="$EPOCHREALTIME" 'BEGIN{printf "%.1f", b - a}'; }

usage() { sed -n '2,10p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; }
case "${1:-}" in
  -h | --help) usage; CLOSED=1; exit 0 ;;
  "") usage >&2; die "missing BUILD_DIR" ;;
esac
[ -d "$1" ] || die "build dir '$1' does not exist"
BUILD=$(cd "$1" && pwd)
shift
WORK=$BUILD/socketcan-vm
mkdir -p "$WORK"

for tool in "$QEMU" busybox cpio gzip modinfo dpkg dpkg-deb apt-get apt-cache cc strip ldd flock timeout; do
  command -v "$tool" >/dev/null || die "'$tool' not found; scripts/install-deps.sh installs what this stage needs"
done
BUSYBOX=$(command -v busybox)

# One run per build dir at a time (the staging dir and console log live there).
exec 8>"$WORK/.lock"
flock -w 300 8 || die "another run.sh holds $WORK/.lock for over 300 s"

# ---------------------------------------------------------------- kernel (cached per package)
# $CACHE/<package>/ holds vmlinuz, modules/<name>.ko (decompressed) and load-order (the modules
# with their dependencies, dependencies first); "ok" holds the module list it was made for.
kernel_package() {
  if [ -n "${DGW_VM_KERNEL_PKG:-}" ]; then
    echo "$DGW_VM_KERNEL_PKG"
    return
  fi
  timeout 60 apt-cache depends linux-image-amd64 2>/dev/null |
    sed -n 's/^ *Depends: \(linux-image-[0-9][^ ]*\)$/\1/p' | head -n 1 || true
}

declare -A MODFILE=() SEEN=()
ORDER=()
# visit NAME: appends NAME's dependencies, then NAME, to ORDER (names use '-', not '_').
visit() {
  local m=${1//_/-} f d deps
  [ -z "${SEEN[$m]:-}" ] || return 0
  SEEN[$m]=1
  f=${MODFILE[$m]:-}
  if [ -z "$f" ]; then
    grep -qE "/${1//-/[-_]}\.ko" "$ROOT/lib/modules/$KVER/modules.builtin" 2>/dev/null && return 0
    die "kernel module '$m' is neither in the package nor built in"
  fi
  deps=$(modinfo -F depends "$f") || die "modinfo $f failed"
  for d in ${deps//,/ }; do visit "$d"; done
  ORDER+=("$m")
}

fetch_kernel() {
  local pkg=$1 kdir=$CACHE/$1 tmp t0 deb f m
  [ "$(cat "$kdir/ok" 2>/dev/null)" = "$MODULES" ] && return 0
  exec 9>"$CACHE/.lock"
  flock -w 900 9 || die "another run.sh holds $CACHE/.lock for over 900 s"
  if [ "$(cat "$kdir/ok" 2>/dev/null)" = "$MODULES" ]; then exec 9>&-; return 0; fi
  tmp=$(mktemp -d "$CACHE/.fetch.XXXXXX")
  TMPDIRS+=("$tmp")
  say "downloading $pkg into $CACHE (once per kernel version)"
  t0=$EPOCHREALTIME
  if ! (cd "$tmp" && timeout 600 apt-get download -q -o APT::Sandbox::User=root "$pkg"); then
    [ "$(id -u)" -eq 0 ] || die "apt-get download $pkg failed (try: apt-get update)"
    say "download failed; refreshing the package lists once (apt-get update)"
    timeout 600 apt-get update -qq || die "apt-get update failed"
    (cd "$tmp" && timeout 600 apt-get download -q -o APT::Sandbox::User=root "$pkg") ||
      die "apt-get download $pkg failed; is a Debian mirror reachable?"
  fi
  deb=$(ls "$tmp"/*.deb)
  say "downloaded $(du -m "$deb" | cut -f1) MB in $(secs_since "$t0") s"
  t0=$EPOCHREALTIME
  ROOT=$tmp/root
  timeout 300 dpkg -x "$deb" "$ROOT" || die "dpkg -x $deb failed"
  rm -f "$deb"
  KVER=$(ls "$ROOT/lib/modules" | head -n 1)
  [ -n "$KVER" ] && [ -f "$ROOT/boot/vmlinuz-$KVER" ] || die "$pkg has no /boot/vmlinuz-* and /lib/modules/*"
  while IFS= read -r f; do
    m=${f##*/}
    m=${m%%.ko*}
    MODFILE[${m//_/-}]=$f
  done < <(find "$ROOT/lib/modules/$KVER" -name '*.ko*')
  for m in $MODULES; do visit "$m"; done
  rm -rf "$kdir"
  mkdir -p "$kdir/modules"
  cp "$ROOT/boot/vmlinuz-$KVER" "$kdir/vmlinuz"
  for m in "${ORDER[@]}"; do
    f=${MODFILE[$m]}
    case "$f" in
      *.ko.xz) xz -dc "$f" >"$kdir/modules/$m.ko" ;;
      *.ko.zst) zstd -qdc "$f" >"$kdir/modules/$m.ko" ;;
      *.ko.gz) gzip -dc "$f" >"$kdir/modules/$m.ko" ;;
      *) cp "$f" "$kdir/modules/$m.ko" ;;
    esac
  done
  echo "$KVER" >"$kdir/kernel-version"
  echo "${ORDER[*]}" >"$kdir/load-order"
  echo "$MODULES" >"$kdir/ok"
  rm -rf "$tmp"
  say "unpacked kernel $KVER and modules (${ORDER[*]}) in $(secs_since "$t0") s"
  exec 9>&-
}

mkdir -p "$CACHE"
PKG=$(kernel_package)
if [ -z "$PKG" ]; then
  # No package lists (or no network): use the newest cached kernel if there is one.
  PKG=$(cd "$CACHE" && ls -t */ok 2>/dev/null | head -n 1 | cut -d/ -f1 || true)
  [ -n "$PKG" ] || die "cannot resolve linux-image-amd64's kernel package (run apt-get update, or set DGW_VM_KERNEL_PKG)"
  say "apt-cache cannot resolve linux-image-amd64; using cached $PKG"
fi
fetch_kernel "$PKG"
KDIR=$CACHE/$PKG
KVER=$(cat "$KDIR/kernel-version")

# ---------------------------------------------------------------- the smoke program
SMOKE=$WORK/can_raw_smoke
if [ ! -x "$SMOKE" ] || [ "$HERE/can_raw_smoke.c" -nt "$SMOKE" ]; then
  cc -std=c11 -D_GNU_SOURCE -O2 -Wall -Wextra -Werror -static -o "$SMOKE.tmp" "$HERE/can_raw_smoke.c" ||
    die "cannot build $HERE/can_raw_smoke.c"
  mv "$SMOKE.tmp" "$SMOKE"
fi

# ---------------------------------------------------------------- the tests
# TESTS: "NAME KIND COMMAND" lines, @words still to be resolved.
TESTS=()
is_elf() { [ "$(head -c 4 "$1" 2>/dev/null | od -An -c | tr -d ' ')" = '177ELF' ]; }
guess_kind() {
  if grep -qa -m 1 'gtest_list_tests' "$1" || ldd "$1" 2>/dev/null | grep -q libgtest; then
    echo gtest
  else
    echo exit
  fi
}
add_binary() {
  local path=$1 name
  name=$(basename "$path")
  [ -f "$path" ] && [ -x "$path" ] || die "test binary '$path' does not exist or is not executable"
  TESTS+=("$name $(guess_kind "$path") @$path")
}
if [ $# -gt 0 ]; then
  for t in "$@"; do
    if [ "$t" = can_raw_smoke ]; then
      TESTS+=("can_raw_smoke exit @$SMOKE vcan0")
    else
      add_binary "$(realpath -- "$t")"
    fi
  done
else
  [ -f "$LIST" ] || die "test list $LIST not found"
  while IFS= read -r line || [ -n "$line" ]; do
    line=${line%%$'\r'}
    case "$line" in '' | '#'*) continue ;; esac
    TESTS+=("$line")
  done <"$LIST"
  while IFS= read -r f; do
    is_elf "$f" || continue
    grep -Fq "@${f#"$BUILD"/}" "$LIST" && continue
    add_binary "$f"
  done < <(find "$BUILD/tests" -type f -perm -u+x \( -name '*socketcan*' -o -name '*vcan*' \) \
    ! -name '*.cmake' 2>/dev/null | LC_ALL=C sort)
fi
PLANNED=${#TESTS[@]}
[ "$PLANNED" -gt 0 ] || die "no tests to run"

# ---------------------------------------------------------------- the initramfs
STAGE=$WORK/initramfs
rm -rf "$STAGE"
mkdir -p "$STAGE"/{bin,dev,proc,sys,tmp,etc,root,lib/modules,opt/dgw/bin,usr}
ln -s bin "$STAGE/sbin"
ln -s ../bin "$STAGE/usr/bin"
ln -s ../bin "$STAGE/usr/sbin"
declare -A STAGED=() LIBDIRS=()

# stage_file HOST_PATH DEST_IN_VM: copies (debug info stripped) plus the shared libraries and the
# dynamic loader it needs, at their host paths.
stage_file() {
  local src=$1 dest=$2 lib line
  [ -z "${STAGED[$dest]:-}" ] || return 0
  STAGED[$dest]=1
  mkdir -p "$STAGE$(dirname "$dest")"
  strip --strip-debug -o "$STAGE$dest" "$src" 2>/dev/null || cp -L "$src" "$STAGE$dest"
  chmod a+rx "$STAGE$dest"
  is_elf "$src" || return 0
  while read -r line; do
    case "$line" in
      *"=> not found"*) die "$src needs ${line%% *}, which ldd cannot find" ;;
      *"=> /"*) lib=${line#*=> }; lib=${lib%% (*} ;;
      /*) lib=${line%% (*} ;;
      *) continue ;;
    esac
    LIBDIRS[$(dirname "$lib")]=1
    stage_file "$lib" "$lib"
  done < <(ldd "$src" 2>/dev/null || true)
}

stage_file "$BUSYBOX" /bin/busybox
for a in $("$BUSYBOX" --list); do
  [ "$a" = busybox ] || ln -sf busybox "$STAGE/bin/$a"
done
cp "$HERE/init.sh" "$STAGE/init"
chmod 755 "$STAGE/init"
cp "$KDIR"/modules/*.ko "$STAGE/lib/modules/"

: >"$STAGE/etc/dgw-tests"
declare -A VMNAME=()
for t in "${TESTS[@]}"; do
  read -r name kind rest <<<"$t"
  case "$kind" in gtest | exit) ;; *) die "test '$name': kind '$kind' is not gtest or exit" ;; esac
  # Replace each @PATH word by the file's path in the VM; everything else stays byte for byte.
  out=""
  while [[ $rest =~ ^(([^@]*[[:space:]])?)@([^[:space:]]+)(.*)$ ]]; do
    out+=${BASH_REMATCH[1]}
    p=${BASH_REMATCH[3]}
    rest=${BASH_REMATCH[4]}
    [ "${p:0:1}" = / ] || p=$BUILD/$p
    [ -f "$p" ] || die "test '$name': $p does not exist (build it first)"
    b=$(basename "$p")
    if [ -n "${VMNAME[$b]:-}" ] && [ "${VMNAME[$b]}" != "$p" ]; then
      die "two different files named $b ($p, ${VMNAME[$b]})"
    fi
    VMNAME[$b]=$p
    stage_file "$p" "/opt/dgw/bin/$b"
    out+=/opt/dgw/bin/$b
  done
  out+=$rest
  echo "$name $kind $out" >>"$STAGE/etc/dgw-tests"
done
cat >"$STAGE/etc/dgw-vm.conf" <<EOF
DGW_MODULES='$(cat "$KDIR/load-order")'
DGW_TEST_TIMEOUT=$TEST_TIMEOUT
DGW_TEST_COUNT=$PLANNED
LD_LIBRARY_PATH='$(IFS=:; echo "${!LIBDIRS[*]}")'
EOF
INITRD=$WORK/initrd.cpio.gz
(cd "$STAGE" && find . -print0 | LC_ALL=C sort -z | cpio --null -o -H newc -R 0:0 --quiet) |
  gzip -1 >"$INITRD.tmp"
mv "$INITRD.tmp" "$INITRD"
say "initramfs: $(du -sm "$STAGE" | cut -f1) MB unpacked, $(du -m "$INITRD" | cut -f1) MB gzipped; kernel $KVER; $PLANNED test(s)"

# ---------------------------------------------------------------- boot
LOG=$WORK/console.log
say "booting qemu (TCG; hard timeout ${VM_TIMEOUT} s); console in $LOG"
T_BOOT=$EPOCHREALTIME
set +e
timeout -k 5 "$VM_TIMEOUT" "$QEMU" -accel tcg -cpu max -m "$MEM" -smp 1 -nographic -no-reboot \
  -vga none -net none -kernel "$KDIR/vmlinuz" -initrd "$INITRD" \
  -append 'console=ttyS0 panic=-1 quiet' </dev/null 2>&1 |
  sed -u 's/\r//g; s/\x1b\[[0-9;?]*[A-Za-z]//g; s/\x1bc/\n/g; s/\x1b[=>]//g' | tee "$LOG"
QRC=${PIPESTATUS[0]}
set -e
QEMU_SECS=$(secs_since "$T_BOOT")

# ---------------------------------------------------------------- verdict
passed=0
failed=0
echo
while read -r _ name verdict secs reason; do
  if [ "$verdict" = PASS ]; then
    passed=$((passed + 1))
    say "PASS $name ($secs in the VM)"
  else
    failed=$((failed + 1))
    say "FAIL $name ($secs in the VM): $reason"
  fi
done < <(grep '^DGW-VM-TEST ' "$LOG" || true)
result=$(grep -m 1 '^DGW-VM-RESULT ' "$LOG" || true)
if [ -z "$result" ]; then
  case "$QRC" in
    124 | 137) why="qemu killed after the ${VM_TIMEOUT} s timeout" ;;
    *) why="qemu exited with status $QRC" ;;
  esac
  say "FAIL: no result marker from the VM ($why); console log: $LOG"
fi
missing=$((PLANNED - passed - failed))
[ "$missing" -le 0 ] || { say "$missing test(s) did not run"; failed=$((failed + missing)); }
vcan_at=$(sed -n 's/^DGW-VM: modules loaded.*vcan0 up at \([0-9.]*\) s$/\1/p' "$LOG")
marker_at=$(sed -n 's/^DGW-VM-RESULT .*uptime=\([0-9.]*\)$/\1/p' "$LOG")
say "kernel $KVER; vcan0 up at ${vcan_at:-?} s and result marker at ${marker_at:-?} s of VM uptime;" \
  "qemu ${QEMU_SECS} s wall; stage ${T_START:+$(secs_since "$T_START")} s"
CLOSED=1
echo "socketcan-vm: $passed passed, $failed failed"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
