/*
 * TWI master interrupt in assembly: the C version spent ~75 cycles with interrupts off
 * (prologue, switch, epilogue), long enough to make the encoder ISR miss an edge at
 * 200k edges/s. This one saves registers in GPIOR0..2 and SREG in ISR_REG_SREG (board.h)
 * like the encoder ISR: 38..56 cycles from the vector's rjmp to reti (build/bench/fw_bench
 * isr), the longest handler, so it sets the encoder's jittered edge-rate limit.
 * Protocol (board_twi.c starts it): write twi_wleft bytes from twi_wptr, then with a
 * repeated start read twi_rleft bytes to twi_rptr (ACK all but the last), STOP, and set
 * twi_state to DONE, or to ERROR on any other status (NACK, arbitration, bus error).
 * The phase comes from the counters, not from the status code alone: simavr 1.6 reports
 * 0x28 instead of 0x18 after an acknowledged SLA+W and 0x30 instead of 0x20 after a
 * refused one (docs/simulator.md), so 0x18 and 0x28 are handled alike.
 */
#include "board.h"

#define TWCR_RUN ((1 << TWINT) | (1 << TWEN) | (1 << TWIE))
#define TWCR_STOP ((1 << TWINT) | (1 << TWEN) | (1 << TWSTO))

    .section .bss.twi_vars,"aw",@nobits
    .global twi_sla, twi_wleft, twi_rleft, twi_state, twi_wptr, twi_rptr
twi_sla:    .skip 1
twi_wleft:  .skip 1
twi_rleft:  .skip 1
twi_state:  .skip 1
twi_wptr:   .skip 2
twi_rptr:   .skip 2

    .text                                 ; before the C code: the vectors reach it with rjmp (Makefile)
    .global TWI_VECT
TWI_VECT:
    out  _SFR_IO_ADDR(ISR_SAVE0), r24
    in   ISR_REG_SREG, _SFR_IO_ADDR(SREG)
    out  _SFR_IO_ADDR(ISR_SAVE2), r25
    out  _SFR_IO_ADDR(ISR_SAVE1), r30
    push r31
    lds  r24, _SFR_MEM_ADDR(TWSR)
    andi r24, 0xF8
    cpi  r24, 0x28                        ; data (or, in simavr, SLA+W) acknowledged
    breq .Lmt_ack
    cpi  r24, 0x50                        ; byte received, ACK sent
    breq .Lmr_data_ack
    cpi  r24, 0x58                        ; last byte received, NACK sent
    brne 3f
    rjmp .Lmr_data_nack
3:
    cpi  r24, 0x08                        ; START
    breq .Lstart
    cpi  r24, 0x10                        ; repeated START
    breq .Lstart
    cpi  r24, 0x18                        ; SLA+W acknowledged (real hardware)
    breq .Lmt_ack
    cpi  r24, 0x40                        ; SLA+R acknowledged
    brne 4f
    rjmp .Lmr_sla_ack
4:
    ldi  r25, TWI_ST_ERROR                ; 0x20, 0x30, 0x48 NACKs, 0x38, 0x00 bus error
    rjmp .Lstop

.Lstart:                                ; address: write phase first, then read
    lds  r24, twi_sla
    lds  r25, twi_wleft
    tst  r25
    brne 1f
    ori  r24, 1
1:  sts  _SFR_MEM_ADDR(TWDR), r24
    ldi  r24, TWCR_RUN
    rjmp .Lout_twcr

.Lmt_ack:
    lds  r25, twi_wleft
    tst  r25
    breq 2f
    dec  r25
    sts  twi_wleft, r25
    lds  r30, twi_wptr
    lds  r31, twi_wptr+1
    ld   r24, Z+
    sts  twi_wptr+1, r31
    sts  twi_wptr, r30
    sts  _SFR_MEM_ADDR(TWDR), r24
    ldi  r24, TWCR_RUN
    rjmp .Lout_twcr
2:  lds  r25, twi_rleft                   ; all written: read next, or finish
    tst  r25
    breq .Ldone_ok
    ldi  r24, TWCR_RUN | (1 << TWSTA)
    rjmp .Lout_twcr

.Lmr_data_ack:
    lds  r30, twi_rptr
    lds  r31, twi_rptr+1
    lds  r24, _SFR_MEM_ADDR(TWDR)
    st   Z+, r24
    sts  twi_rptr+1, r31
    sts  twi_rptr, r30
    lds  r25, twi_rleft
    dec  r25
    sts  twi_rleft, r25
.Lack_next:                             ; r25 = bytes still to read: NACK the last
    ldi  r24, TWCR_RUN
    cpi  r25, 2
    brlo .Lout_twcr
    ldi  r24, TWCR_RUN | (1 << TWEA)
    rjmp .Lout_twcr

.Lmr_sla_ack:
    lds  r25, twi_rleft
    rjmp .Lack_next

.Lmr_data_nack:
    lds  r30, twi_rptr
    lds  r31, twi_rptr+1
    lds  r24, _SFR_MEM_ADDR(TWDR)
    st   Z+, r24
    sts  twi_rptr+1, r31
    sts  twi_rptr, r30
    lds  r25, twi_rleft
    dec  r25
    sts  twi_rleft, r25
.Ldone_ok:
    ldi  r25, TWI_ST_DONE
.Lstop:
    ldi  r24, TWCR_STOP
    sts  _SFR_MEM_ADDR(TWCR), r24
    sts  twi_state, r25
    ldi  r24, 0                           ; the main loop has work: no sleep (board_idle;
    out  _SFR_IO_ADDR(SMCR), r24          ; SE is the only bit it ever sets)
    rjmp .Lexit

.Lout_twcr:
    sts  _SFR_MEM_ADDR(TWCR), r24
.Lexit:
    pop  r31
    in   r30, _SFR_IO_ADDR(ISR_SAVE1)
    in   r25, _SFR_IO_ADDR(ISR_SAVE2)
    out  _SFR_IO_ADDR(SREG), ISR_REG_SREG
    in   r24, _SFR_IO_ADDR(ISR_SAVE0)
    reti
