/*
 * Hand-written interrupt code, where C's prologue costs too much:
 *  - the encoder pin-change ISR (X4 decoding at up to 200k edges/s),
 *  - the 1 kHz tick ISR (it only counts),
 *  - the .init3 boot code: capture MCUSR, stop a watchdog left running, paint the stack.
 */
#include "board.h"

    .global __do_clear_bss

/* ---- data ------------------------------------------------------------------------------- */
    .section .bss.enc_isr_vars,"aw",@nobits
    .global enc_isr_illegal, board_tick, board_wake_tick
enc_isr_illegal: .skip 2
board_tick:      .skip 1
board_wake_tick: .skip 1

    .section .noinit.fw_reset_cause,"aw",@nobits
    .global fw_reset_cause, fw_wdt_marker
fw_reset_cause:  .skip 1    ; .noinit: .init4 clears .bss after .init3 wrote this
fw_wdt_marker:   .skip 2    ; WDT_MARKER0/1 written by the watchdog interrupt, survives the reset

/* ---- encoder: PCINT2 on PD2 (A) / PD3 (B) ------------------------------------------------
 * PIND is read by the second instruction, so a following edge only needs to come after
 * that to be seen as a separate step (it sets the flag again and the ISR runs once more).
 * Table: enc_isr_table (board.c), 256 bytes of flash, 256-aligned, entry at
 * (new_ab << 2) | (old_ab << 6): new_ab << 2 is PIND & 0x0C as read, and `swap` turns it
 * into the next edge's old_ab << 6, so no shifts. Entries: 0, +1, 0xFF (-1) or ENC_ILLEGAL
 * (0x80). The previous pin state, the count and SREG live in registers that only the ISRs
 * use (board.h, ISR_REG_*: the C code is compiled with -ffixed-r2..r5, the image checked by
 * check-isr-regs.sh at every build), so only r30:r31 are saved (GPIOR0..1); the high byte
 * of the count changes only when +1 carries out of the low byte or -1 (0xFF) does not.
 * Cost, measured in simavr (build/bench/fw_bench isr, docs/benchmarks.md): 28 cycles per
 * edge from the vector's rjmp to reti inclusive on the common path (was 38 with the state
 * and count in RAM); the chip adds its 4 cycles of interrupt response (8 when it wakes
 * from sleep), which simavr does not model.
 */
    .text                                 ; before the C code: the vectors reach it with rjmp (Makefile)
    .global ENC_VECT
ENC_VECT:
    out  _SFR_IO_ADDR(ISR_SAVE0), r30
    in   r30, _SFR_IO_ADDR(ENC_PIN)       ; sample the pins first
    out  _SFR_IO_ADDR(ISR_SAVE1), r31
    in   ISR_REG_SREG, _SFR_IO_ADDR(SREG)
    andi r30, ENC_AB_MASK                 ; new_ab << 2
    mov  r31, r30
    or   r30, ISR_REG_ENC_PREV            ; table index
    swap r31                              ; new_ab << 6: old_ab of the next edge
    mov  ISR_REG_ENC_PREV, r31
    ldi  r31, hi8(enc_isr_table)          ; lo8(enc_isr_table) is 0 (256-aligned)
    lpm  r30, Z                           ; delta: 0, +1, 0xFF or ENC_ILLEGAL (0x80)
    cpi  r30, 0x80
    breq 4f
    add  ISR_REG_ENC_LO, r30
    brcs 2f
    sbrc r30, 7
    dec  ISR_REG_ENC_HI                   ; -1 without carry: borrow
1:  out  _SFR_IO_ADDR(SREG), ISR_REG_SREG
    in   r31, _SFR_IO_ADDR(ISR_SAVE1)
    in   r30, _SFR_IO_ADDR(ISR_SAVE0)
    reti
2:  sbrs r30, 7
    inc  ISR_REG_ENC_HI                   ; +1 with carry (-1 with carry: the high byte stays)
    rjmp 1b
4:  lds  r30, enc_isr_illegal
    lds  r31, enc_isr_illegal+1
    adiw r30, 1
    sts  enc_isr_illegal+1, r31
    sts  enc_isr_illegal, r30
    rjmp 1b

/* ---- 1 kHz tick: Timer2 compare A ---------------------------------------------------------
 * Counts, and wakes the main loop (clears SE, board_idle) only at the tick it asked for
 * (board_wake_tick) or when a byte has arrived since it last drained the RX ring
 * (uart_rx_new): on the other ticks there is nothing for it to do. SREG in ISR_REG_SREG
 * (board.h). */
    .text                                 ; before the C code: the vectors reach it with rjmp (Makefile)
    .global TICK_VECT
TICK_VECT:
    out  _SFR_IO_ADDR(ISR_SAVE0), r24
    in   ISR_REG_SREG, _SFR_IO_ADDR(SREG)
    out  _SFR_IO_ADDR(ISR_SAVE1), r25
    lds  r24, board_tick
    subi r24, 0xFF                        ; +1
    sts  board_tick, r24
    lds  r25, board_wake_tick
    cp   r24, r25
    breq 1f
    lds  r25, uart_rx_new
    tst  r25
    breq 2f
1:  ldi  r24, 0                           ; the main loop has work: no sleep (board_idle;
    out  _SFR_IO_ADDR(SMCR), r24          ; SE is the only bit it ever sets)
2:  in   r25, _SFR_IO_ADDR(ISR_SAVE1)
    out  _SFR_IO_ADDR(SREG), ISR_REG_SREG
    in   r24, _SFR_IO_ADDR(ISR_SAVE0)
    reti

/* ---- watchdog interrupt: the first watchdog timeout (WDIE + WDE mode) -------------------
 * Optiboot 4.4 (Arduino's, Debian's) clears MCUSR before starting the application and
 * does not pass it on, so WDRF is lost. The watchdog runs in interrupt-then-reset mode:
 * the first timeout lands here and leaves a marker in .noinit RAM, the second resets,
 * and the boot code below reads the marker. 12 cycles; no flags touched. */
    .text                                 ; before the C code: the vectors reach it with rjmp (Makefile)
    .global WDT_VECT
WDT_VECT:
    out  _SFR_IO_ADDR(ISR_SAVE0), r24
    ldi  r24, WDT_MARKER0
    sts  fw_wdt_marker, r24
    ldi  r24, WDT_MARKER1
    sts  fw_wdt_marker+1, r24
    in   r24, _SFR_IO_ADDR(ISR_SAVE0)
    reti

/* ---- boot, .init3: after the stack pointer and r1 are set up, before .data and .bss ------
 * MCUSR must be cleared before the watchdog can be stopped (WDRF forces WDE on), and the
 * watchdog must be stopped at once: after a watchdog reset it keeps running at its shortest
 * period, and simavr 1.6 leaves WDE set after Optiboot's reset. The watchdog marker adds
 * WDRF when a bootloader has cleared MCUSR. */
    .section .init3,"ax",@progbits
    in   r24, _SFR_IO_ADDR(MCUSR)
    lds  r25, fw_wdt_marker
    cpi  r25, WDT_MARKER0
    brne 1f
    lds  r25, fw_wdt_marker+1
    cpi  r25, WDT_MARKER1
    brne 1f
    ori  r24, (1 << WDRF)
1:  sts  fw_reset_cause, r24
    sts  fw_wdt_marker, r1
    sts  fw_wdt_marker+1, r1
    out  _SFR_IO_ADDR(MCUSR), r1
    ldi  r24, (1 << WDCE) | (1 << WDE)
    sts  _SFR_MEM_ADDR(WDTCSR), r24
    sts  _SFR_MEM_ADDR(WDTCSR), r1
    /* Paint [__heap_start, SP) with STACK_PAINT: the lowest overwritten byte shows the
     * deepest the stack has grown (board_stack_unused, or the simulator reading RAM). */
    ldi  r30, lo8(__heap_start)
    ldi  r31, hi8(__heap_start)
    in   r24, _SFR_IO_ADDR(SPL)
    in   r25, _SFR_IO_ADDR(SPH)
    ldi  r18, STACK_PAINT
2:  st   Z+, r18
    cp   r30, r24
    cpc  r31, r25
    brlo 2b
