#!/usr/bin/env bash
# Flash a motor module through its Optiboot bootloader, then (with ID) set its id through the
# protocol's CONFIG frame: Optiboot cannot write EEPROM. Called by `make flash`.
#   scripts/flash-module.sh PORT HEX [ID]
# Environment: AVRDUDE (avrdude), FLASH_BAUD (115200, Optiboot's rate on a 16 MHz board),
# AUGER_MODULE (the auger-module tool).
set -euo pipefail
if [[ $# -lt 2 || $# -gt 3 ]]; then
  echo "usage: $0 PORT HEX [ID]" >&2
  exit 2
fi
port=$1 hex=$2 id=${3:-}
avrdude=${AVRDUDE:-avrdude}
baud=${FLASH_BAUD:-115200}
tool=${AUGER_MODULE:-$(dirname "$0")/../build/host/tools/auger-module}
[[ -e $port ]] || { echo "flash-module: $port: no such port" >&2; exit 1; }
[[ -r $hex ]] || { echo "flash-module: $hex: no firmware image (make firmware)" >&2; exit 1; }
if [[ -n $id && ! $id =~ ^[0-9]+$ ]]; then
  echo "flash-module: ID must be a number 0..255, got '$id'" >&2
  exit 2
fi

"$avrdude" -q -q -c arduino -p m328p -P "$port" -b "$baud" -D -U "flash:w:$hex:i"
echo "flash-module: $port: flashed $hex"
if [[ -n $id ]]; then
  "$tool" "$port" set "id=$id"
else
  "$tool" "$port" identify
fi
