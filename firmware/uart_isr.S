/*
 * USART0 interrupts in assembly. They run once per byte (3300 bytes/s of telemetry out,
 * 1100 of setpoints in); the C versions measured 51..144 cycles (mean 69, TX) and 78..129
 * (mean 81, RX) and re-enabled interrupts part-way so the encoder ISR could preempt them.
 * These take 26..28 (TX) and 40 (RX) cycles, rjmp to reti, measured by build/bench/fw_bench
 * (docs/benchmarks.md): shorter than the TWI ISR (38..56), so interrupts stay off all along.
 * They save registers in GPIOR0..2 and SREG in ISR_REG_SREG like the other assembly ISRs
 * (board.h: none of them enables interrupts, so they never nest).
 * The rings are board_uart.c's. The RX ISR does not wake the main loop: it sets
 * uart_rx_new, and the next 1 kHz tick wakes the loop to drain the ring.
 */
#include "board.h"

#if (UART_RX_SIZE & (UART_RX_SIZE - 1)) || (UART_TX_SIZE & (UART_TX_SIZE - 1)) || \
    UART_RX_SIZE > 128 || UART_TX_SIZE > 128
#error "ring sizes must be powers of two up to 128"
#endif

/* ---- receive: store the byte, count a lost one -----------------------------------------
 * uart_rx_overflows_count counts a byte lost to a full ring or to a hardware overrun
 * (DOR0), once if both (as the C handler did). T marks "counted"; SREG is restored. */
    .text                                 ; before the C code: the vectors reach it with rjmp (Makefile)
    .global UART_RX_VECT
UART_RX_VECT:
    out  _SFR_IO_ADDR(ISR_SAVE0), r30
    in   ISR_REG_SREG, _SFR_IO_ADDR(SREG)
    out  _SFR_IO_ADDR(ISR_SAVE1), r31
    lds  r31, _SFR_MEM_ADDR(UCSR0A)       ; DOR0 is valid until UDR0 is read
    clt
    sbrc r31, DOR0
    rcall 3f                              ; hardware overrun: count it, set T (rare)
    out  _SFR_IO_ADDR(ISR_SAVE2), r24
    lds  r30, uart_rx_head
    mov  r31, r30
    inc  r31
    andi r31, UART_RX_SIZE - 1            ; next head
    lds  r24, uart_rx_tail
    cp   r31, r24
    lds  r24, _SFR_MEM_ADDR(UDR0)         ; the byte, clears RXC0 (lds keeps the flags)
    breq 4f                               ; ring full
    sts  uart_rx_head, r31                ; the ISR is atomic for the loop: order is free
    ldi  r31, 0
    subi r30, lo8(-(uart_rx_buf))
    sbci r31, hi8(-(uart_rx_buf))
    st   Z, r24
    ldi  r24, 1
    sts  uart_rx_new, r24                 ; the tick ISR wakes the loop to drain the ring
1:  in   r24, _SFR_IO_ADDR(ISR_SAVE2)
    in   r31, _SFR_IO_ADDR(ISR_SAVE1)
    out  _SFR_IO_ADDR(SREG), ISR_REG_SREG
    in   r30, _SFR_IO_ADDR(ISR_SAVE0)
    reti
4:  brts 1b                               ; full, and the overrun already counted
    rcall 5f
    rjmp 1b
3:  set
5:  lds  r30, uart_rx_overflows_count     ; subroutine: r30, r31 are free where called
    lds  r31, uart_rx_overflows_count+1
    adiw r30, 1
    sts  uart_rx_overflows_count+1, r31
    sts  uart_rx_overflows_count, r30
    ret

/* ---- data register empty: next byte, or mask this interrupt when the ring is empty ----
 * UDRE0 stays set while UDR0 is empty, so an empty ring must clear UDRIE0; uart_write sets
 * it again after queueing a frame. */
    .text                                 ; before the C code: the vectors reach it with rjmp (Makefile)
    .global UART_UDRE_VECT
UART_UDRE_VECT:
    out  _SFR_IO_ADDR(ISR_SAVE0), r30
    in   ISR_REG_SREG, _SFR_IO_ADDR(SREG)
    out  _SFR_IO_ADDR(ISR_SAVE1), r31
    lds  r30, uart_tx_tail
    lds  r31, uart_tx_head
    cp   r30, r31
    breq 2f
    ori  r30, lo8(uart_tx_buf)            ; the ring is aligned to its size (board_uart.c):
    ldi  r31, hi8(uart_tx_buf)            ; its address is hi8:(lo8 | tail)
    ld   r31, Z
    sts  _SFR_MEM_ADDR(UDR0), r31
    inc  r30
    andi r30, UART_TX_SIZE - 1            ; (also drops the lo8 bits)
    sts  uart_tx_tail, r30
1:  in   r31, _SFR_IO_ADDR(ISR_SAVE1)
    out  _SFR_IO_ADDR(SREG), ISR_REG_SREG
    in   r30, _SFR_IO_ADDR(ISR_SAVE0)
    reti
2:  lds  r30, _SFR_MEM_ADDR(UCSR0B)
    andi r30, ~(1 << UDRIE0) & 0xFF
    sts  _SFR_MEM_ADDR(UCSR0B), r30
    rjmp 1b
