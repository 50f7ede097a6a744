#!/usr/bin/env bash
# Flash all four motor modules and give each its id: the module on the n-th port gets id n
# (0 front-right, 1 rear-right, 2 rear-left, 3 front-left, the screw indices of the model).
# Each is flashed through Optiboot and its id set by scripts/flash-module.sh; then every
# module is opened again (which resets it) and must answer with its id and the firmware
# version of the image. Called by `make flash-all`; installed with flash-module.sh under
# PREFIX/share/auger/flash/ (docs/board.md).
#   scripts/flash-all.sh PORT0 PORT1 PORT2 PORT3
# Environment: HEX (the image: auger-module.hex next to this script if there, else
# firmware/build/auger-module.hex), AUGER_MODULE (the auger-module tool: `auger-module` on
# PATH, else build/host/tools/auger-module), and AVRDUDE / FLASH_BAUD for flash-module.sh.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
if [[ $# -ne 4 ]]; then
  echo "usage: $0 PORT0 PORT1 PORT2 PORT3   (the module on PORTn gets id n)" >&2
  exit 2
fi
ports=("$@")
hex=${HEX:-}
if [[ -z $hex ]]; then
  hex=$here/auger-module.hex
  [[ -r $hex ]] || hex=$here/../firmware/build/auger-module.hex
fi
tool=${AUGER_MODULE:-}
if [[ -z $tool ]]; then
  tool=$(command -v auger-module || true)
  [[ -n $tool ]] || tool=$here/../build/host/tools/auger-module
fi
[[ -x $tool ]] || { echo "flash-all: $tool: no auger-module tool (make board / make install, or AUGER_MODULE=...)" >&2; exit 1; }
[[ -r $hex ]] || { echo "flash-all: $hex: no firmware image (make firmware, or copy it, or HEX=...)" >&2; exit 1; }
for i in 0 1 2 3; do
  [[ -e ${ports[$i]} ]] || { echo "flash-all: ${ports[$i]} (id $i): no such port" >&2; exit 1; }
  for ((j = 0; j < i; j++)); do
    [[ $(readlink -f "${ports[$i]}") != $(readlink -f "${ports[$j]}") ]] ||
      { echo "flash-all: ${ports[$j]} and ${ports[$i]} are the same port" >&2; exit 2; }
  done
done
# The version the image carries, which each identity frame must report: FW_VERSION if given,
# else firmware/config.h of this source tree (the .hex itself does not say it); installed on the
# board without the sources, every module must at least report the same version as module 0.
version=${FW_VERSION:-}
config_h=$here/../firmware/config.h
if [[ -z $version && -r $config_h ]]; then
  version=$(awk '/#define FW_VERSION_(MAJOR|MINOR|PATCH)/ { v = v (v == "" ? "" : ".") $3 } END { print v }' "$config_h")
fi
export AUGER_MODULE=$tool
for i in 0 1 2 3; do
  echo "flash-all: module $i on ${ports[$i]}"
  bash "$here/flash-module.sh" "${ports[$i]}" "$hex" "$i" ||
    { echo "flash-all: module $i on ${ports[$i]}: flashing or setting the id failed" >&2; exit 1; }
done
# Check: a fresh open resets each module; it must come back from EEPROM with its id.
failed=0
for i in 0 1 2 3; do
  out=$("$tool" "${ports[$i]}" identify 2>&1) || true
  echo "$out"
  if [[ ! $out =~ :\ module\ $i,\ firmware\ ([0-9]+\.[0-9]+\.[0-9]+),.*settings\ from\ EEPROM ]]; then
    echo "flash-all: ${ports[$i]}: expected module $i with settings from EEPROM" >&2
    failed=1
    continue
  fi
  v=${BASH_REMATCH[1]}
  if [[ -z $version ]]; then
    version=$v
  elif [[ $v != "$version" ]]; then
    echo "flash-all: ${ports[$i]}: firmware $v, expected $version" >&2
    failed=1
  fi
done
((failed == 0)) || exit 1
echo "flash-all: modules 0-3 answer with their ids, firmware $version"
