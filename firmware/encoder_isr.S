/*
 * Hand-written interrupt code, where C's prologue costs too much:
 *  - the encoder pin-change ISR (X4 decoding at up to 200k edges/s),
 *  - the 1 kHz tick ISR (it only counts),
 *  - the .init3 boot code: capture MCUSR, stop a watchdog left running, paint the stack.
 */
#include "board.h"

    .global __do_clear_bss

/* ---- data ------------------------------------------------------------------------------- */
    .section .bss.enc_isr_table,"aw",@nobits
    .balign 16
    .global enc_isr_table
enc_isr_table:  .skip 16    ; copy of enc_transition_table (enc.c), filled by board_init

    .section .bss.enc_isr_vars,"aw",@nobits
    .global enc_isr_prev, enc_isr_count, enc_isr_illegal, board_tick
enc_isr_prev:    .skip 1
enc_isr_count:   .skip 2
enc_isr_illegal: .skip 2
board_tick:      .skip 1

    .section .noinit.fw_reset_cause,"aw",@nobits
    .global fw_reset_cause, fw_wdt_marker
fw_reset_cause:  .skip 1    ; .noinit: .init4 clears .bss after .init3 wrote this
fw_wdt_marker:   .skip 2    ; WDT_MARKER0/1 written by the watchdog interrupt, survives the reset

/* ---- encoder: PCINT2 on PD2 (A) / PD3 (B) ------------------------------------------------
 * PIND is read by the second instruction, 2 cycles after the vector jump, so a following
 * edge only needs to be at least that far away to be seen as a separate step.
 * The table index is (new_ab << 2) | old_ab = (PIND & 0x0C) | old_ab, and enc_isr_prev
 * holds the table's low address byte with old_ab in it (the table is 16-aligned).
 * Cost (cycles, counted from the instruction list; the simulator measures it, see
 * docs/firmware.md): 7 response + vector jump, 48 body = 55 per edge, 57 for an illegal
 * transition. A plain C ISR took about 115.
 */
    .section .text.enc_isr,"ax",@progbits
    .global ENC_VECT
ENC_VECT:
    out  _SFR_IO_ADDR(ISR_SAVE0), r24
    in   r24, _SFR_IO_ADDR(ENC_PIN)       ; sample the pins first
    out  _SFR_IO_ADDR(ISR_SAVE1), r25
    in   r25, _SFR_IO_ADDR(SREG)
    out  _SFR_IO_ADDR(ISR_SAVE2), r25
    push r30
    push r31
    andi r24, ENC_AB_MASK                 ; new_ab << 2
    lds  r30, enc_isr_prev                ; lo8(table) | old_ab
    or   r30, r24
    lsr  r24
    lsr  r24                              ; new_ab
    ori  r24, lo8(enc_isr_table)
    sts  enc_isr_prev, r24
    ldi  r31, hi8(enc_isr_table)
    ld   r24, Z                           ; delta: 0, +1, -1 or ENC_ILLEGAL (0x80)
    cpi  r24, 0x80
    breq 2f
    mov  r25, r24
    lsl  r25
    sbc  r25, r25                         ; sign extension of the delta
    lds  r30, enc_isr_count
    lds  r31, enc_isr_count+1
    add  r30, r24
    adc  r31, r25
    sts  enc_isr_count+1, r31
    sts  enc_isr_count, r30
1:  pop  r31
    pop  r30
    in   r25, _SFR_IO_ADDR(ISR_SAVE2)
    out  _SFR_IO_ADDR(SREG), r25
    in   r25, _SFR_IO_ADDR(ISR_SAVE1)
    in   r24, _SFR_IO_ADDR(ISR_SAVE0)
    reti
2:  lds  r30, enc_isr_illegal
    lds  r31, enc_isr_illegal+1
    adiw r30, 1
    sts  enc_isr_illegal+1, r31
    sts  enc_isr_illegal, r30
    rjmp 1b

/* ---- 1 kHz tick: Timer2 compare A ---------------------------------------------------------
 * Only counts (and cancels a pending sleep); the main loop extends the 8-bit count to the
 * 32-bit module time. 29 cycles. */
    .section .text.tick_isr,"ax",@progbits
    .global TICK_VECT
TICK_VECT:
    push r24
    in   r24, _SFR_IO_ADDR(SREG)
    push r24
    lds  r24, board_tick
    subi r24, 0xFF                        ; +1
    sts  board_tick, r24
    in   r24, _SFR_IO_ADDR(SMCR)
    andi r24, ~(1 << SE) & 0xFF           ; the main loop has work: no sleep (board_idle)
    out  _SFR_IO_ADDR(SMCR), r24
    pop  r24
    out  _SFR_IO_ADDR(SREG), r24
    pop  r24
    reti

/* ---- watchdog interrupt: the first watchdog timeout (WDIE + WDE mode) -------------------
 * Optiboot 4.4 (Arduino's, Debian's) clears MCUSR before starting the application and
 * does not pass it on, so WDRF is lost. The watchdog runs in interrupt-then-reset mode:
 * the first timeout lands here and leaves a marker in .noinit RAM, the second resets,
 * and the boot code below reads the marker. 12 cycles; no flags touched. */
    .section .text.wdt_isr,"ax",@progbits
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
