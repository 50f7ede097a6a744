#!/usr/bin/env bash
# `make install` / `make uninstall` (docs/board.md). Installs the board's binaries, the models,
# the firmware image and the flashing scripts, the configuration (never overwriting one that is
# there), the systemd unit, the service user's sysusers.d entry and the udev rule example, and
# writes a manifest of what it added so that uninstall removes exactly that. The manifest holds
# the paths without DESTDIR: a tree staged with DESTDIR and unpacked on the board uninstalls
# there. Paths must not contain spaces.
#   packaging/install.sh install|uninstall
# Environment (the Makefile passes them): FROM (the CMake build holding host/augerd/augerd,
# host/auger/auger, host/tools/auger-module), DESTDIR (empty), PREFIX (/usr/local),
# SYSCONFDIR (/etc).
set -euo pipefail
src=$(cd "$(dirname "$0")/.." && pwd)
action=${1:-}
FROM=${FROM:-$src/build-aarch64}
DESTDIR=${DESTDIR:-}
PREFIX=${PREFIX:-/usr/local}
SYSCONFDIR=${SYSCONFDIR:-/etc}
bindir=$PREFIX/bin
datadir=$PREFIX/share/auger
unitdir=$PREFIX/lib/systemd/system
manifest=$DESTDIR$datadir/install-manifest
# System actions (create the user, reload systemd) only for a real install into this system's
# /etc, as root; never into a DESTDIR (a staging tree or a package).
system_install() { [[ -z $DESTDIR && $SYSCONFDIR == /etc && $(id -u) -eq 0 ]]; }

die() { echo "install: $*" >&2; exit 1; }

# Directories are recorded when this install creates them, so uninstall removes only those.
entries=()
make_dir() {
  local d=$1 missing=() p=$1
  while [[ ! -d $p ]]; do missing=("$p" "${missing[@]}"); p=$(dirname "$p"); done
  for p in "${missing[@]}"; do
    mkdir -m 0755 "$p"
    entries+=("d ${p#"$DESTDIR"}")
  done
}
# put MODE SOURCE TARGET: copy, or with a sed script in SED substitute the @...@ names.
put() {
  local mode=$1 from=$2 to=$3
  make_dir "$(dirname "$to")"
  if [[ -n ${SED:-} ]]; then
    sed "$SED" "$from" > "$to.tmp-install"
    chmod "$mode" "$to.tmp-install"
    mv -f "$to.tmp-install" "$to"
  else
    install -m "$mode" "$from" "$to"
  fi
  entries+=("f $(sha256sum "$to" | cut -d' ' -f1) ${to#"$DESTDIR"}")
}

do_install() {
  local b
  for b in host/augerd/augerd host/auger/auger host/tools/auger-module; do
    [[ -x $FROM/$b ]] || die "$FROM/$b: not built (make board, or FROM=<a build directory>)"
  done
  [[ ! -e $manifest ]] || die "$manifest exists: already installed here (make uninstall first)"
  local subst="s|@BINDIR@|$bindir|g; s|@SYSCONFDIR@|$SYSCONFDIR|g; s|@DATADIR@|$datadir|g"

  put 0755 "$FROM/host/augerd/augerd" "$DESTDIR$bindir/augerd"
  put 0755 "$FROM/host/auger/auger" "$DESTDIR$bindir/auger"
  put 0755 "$FROM/host/tools/auger-module" "$DESTDIR$bindir/auger-module"
  for m in "$src"/models/*.toml; do put 0644 "$m" "$DESTDIR$datadir/models/$(basename "$m")"; done
  # Flashing from the board: the scripts, and the image when it was built here (otherwise copy
  # firmware/build/auger-module.hex from the workstation next to flash-all.sh).
  put 0755 "$src/scripts/flash-module.sh" "$DESTDIR$datadir/flash/flash-module.sh"
  put 0755 "$src/scripts/flash-all.sh" "$DESTDIR$datadir/flash/flash-all.sh"
  if [[ -r $src/firmware/build/auger-module.hex ]]; then
    put 0644 "$src/firmware/build/auger-module.hex" "$DESTDIR$datadir/flash/auger-module.hex"
  else
    echo "install: firmware/build/auger-module.hex not built: flashing from here needs it copied to $datadir/flash/"
  fi
  put 0644 "$src/packaging/90-auger-modules.rules.example" "$DESTDIR$datadir/udev/90-auger-modules.rules.example"
  SED=$subst put 0644 "$src/packaging/augerd.service.in" "$DESTDIR$unitdir/augerd.service"
  put 0644 "$src/packaging/auger.sysusers" "$DESTDIR$SYSCONFDIR/sysusers.d/auger.conf"
  local conf=$DESTDIR$SYSCONFDIR/auger/augerd.toml
  if [[ -e $conf ]]; then
    echo "install: $conf exists: kept (the new default is $datadir/augerd.toml.default)"
  else
    SED=$subst put 0644 "$src/packaging/augerd.toml.in" "$conf"
  fi
  SED=$subst put 0644 "$src/packaging/augerd.toml.in" "$DESTDIR$datadir/augerd.toml.default"

  make_dir "$(dirname "$manifest")"
  printf '%s\n' "${entries[@]}" > "$manifest"
  echo "install: $(grep -c '^f' "$manifest") files under ${DESTDIR:-/} (list: $manifest)"
  if system_install; then
    command -v systemd-sysusers >/dev/null && systemd-sysusers "$SYSCONFDIR/sysusers.d/auger.conf"
    [[ -d /run/systemd/system ]] && systemctl daemon-reload
    echo "install: next: edit $SYSCONFDIR/auger/augerd.toml, then systemctl enable --now augerd"
  fi
}

do_uninstall() {
  [[ -r $manifest ]] || die "$manifest: no manifest, nothing installed with PREFIX=$PREFIX DESTDIR=$DESTDIR"
  if system_install && [[ -d /run/systemd/system ]]; then
    systemctl disable --now augerd.service 2>/dev/null || true
  fi
  local kind sum path dirs=()
  while read -r kind sum path; do
    case $kind in
      f)
        path=$DESTDIR$path
        [[ -e $path ]] || continue
        # An edited configuration is the operator's: keep it.
        if [[ $(sha256sum "$path" | cut -d' ' -f1) != "$sum" ]]; then
          echo "install: $path changed since install: kept"
        else
          rm -f "$path"
        fi ;;
      d) dirs=("$DESTDIR$sum" "${dirs[@]}") ;;  # "d PATH": the path is the second field
    esac
  done < "$manifest"
  rm -f "$manifest"
  # Deepest first (they were recorded parents first); a directory still holding something that
  # was not ours stays.
  local d
  for d in "${dirs[@]}"; do rmdir "$d" 2>/dev/null || echo "install: $d not empty: kept"; done
  echo "install: uninstalled"
  if system_install; then
    [[ -d /run/systemd/system ]] && systemctl daemon-reload
    echo "install: the user auger stays, as sysusers.d(5) intends (userdel auger to remove it)"
  fi
}

case $action in
  install) do_install ;;
  uninstall) do_uninstall ;;
  *) echo "usage: $0 install|uninstall" >&2; exit 2 ;;
esac
