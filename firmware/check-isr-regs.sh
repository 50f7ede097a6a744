#!/bin/sh
# Fails if any code in the image other than the interrupt handlers and the two accessors
# names a register reserved for the ISRs (board.h, ISR_REG_*). The C code is compiled with
# -ffixed-r2..r5, but libgcc and avr-libc are not: a library routine that used one of them
# would corrupt the encoder count.
#   firmware/check-isr-regs.sh build/auger-module.elf
set -eu
elf=$1
objdump=${OBJDUMP:-avr-objdump}
"$objdump" -d "$elf" | awk -v elf="$elf" '
    /^[0-9a-f]+ <[^>]+>:$/ { fn = $2; gsub(/[<>:]/, "", fn); next }
    fn ~ /^__vector_[0-9]+$/ || fn == "board_init" || fn == "board_encoder_read" { next }
    /^ +[0-9a-f]+:\t/ {
        n = split($0, f, "\t")
        ops = n >= 4 ? f[4] : ""
        if (ops ~ /(^|[ ,])r[2-5]($|[ ,;])/) { printf "%s: %s uses a register reserved for the ISRs:%s\n", elf, fn, $0; bad = 1 }
    }
    END { exit bad }'
