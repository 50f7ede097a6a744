/* Interrupt-driven USART0 at 250000 baud with ring buffers both ways; never blocks. */
#include "board.h"

#include <avr/interrupt.h>
#include <util/atomic.h>

#define RX_SIZE 64u  /* 2.5 ms of input at 250000 baud; the loop drains it every tick */
#define TX_SIZE 128u /* four telemetry frames */
#if (RX_SIZE & (RX_SIZE - 1u)) || (TX_SIZE & (TX_SIZE - 1u)) || RX_SIZE > 256 || TX_SIZE > 256
#error "ring sizes must be powers of two up to 256"
#endif

static volatile uint8_t rx_buf[RX_SIZE];
static volatile uint8_t rx_head, rx_tail; /* ISR writes head, loop writes tail */
static volatile uint16_t rx_overflows;
static volatile uint8_t tx_buf[TX_SIZE];
static volatile uint8_t tx_head, tx_tail; /* loop writes head, ISR writes tail */
static uint16_t tx_dropped;

void uart_init(void)
{
    UCSR0A = (1 << U2X0); /* before UBRR (simavr computes the baud rate on the UBRR write) */
    UBRR0H = (uint8_t)(UART_UBRR >> 8);
    UBRR0L = (uint8_t)(UART_UBRR & 0xFFu);
    UCSR0C = (1 << UCSZ01) | (1 << UCSZ00); /* 8N1 */
    UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
}

/* Both UART handlers re-enable interrupts as soon as their own source is quiet, so the
 * encoder ISR can preempt them (their prologues alone cost ~20 cycles with interrupts off;
 * the whole handler ~57). The assembly ISRs never do this, so they never nest. */
ISR(UART_RX_VECT)
{
    uint8_t status = UCSR0A;
    uint8_t byte = UDR0; /* clears RXC0: this interrupt cannot come back for a byte time */
    sei();
    SMCR &= (uint8_t)~(1 << SE); /* the main loop has work: no sleep (board_idle) */
    uint8_t next = (uint8_t)((rx_head + 1u) & (RX_SIZE - 1u));
    if ((status & (1 << DOR0)) || next == rx_tail) rx_overflows++;
    if (next != rx_tail) {
        rx_buf[rx_head] = byte;
        rx_head = next;
    }
}

ISR(UART_UDRE_VECT)
{
    /* UDRE0 stays set while the data register is empty, so mask this source before
     * enabling interrupts, and unmask it with interrupts off at the end. */
    UCSR0B &= (uint8_t)~(1 << UDRIE0);
    sei();
    uint8_t tail = tx_tail;
    if (tail == tx_head) return; /* ring empty: stay masked until uart_write */
    UDR0 = tx_buf[tail];
    tx_tail = (uint8_t)((tail + 1u) & (TX_SIZE - 1u));
    cli();
    UCSR0B |= (1 << UDRIE0);
}

bool uart_rx_pending(void) { return rx_head != rx_tail; }

bool uart_read(uint8_t *byte)
{
    uint8_t tail = rx_tail;
    if (tail == rx_head) return false;
    *byte = rx_buf[tail];
    rx_tail = (uint8_t)((tail + 1u) & (RX_SIZE - 1u));
    return true;
}

bool uart_write(const uint8_t *data, uint8_t len)
{
    uint8_t head = tx_head;
    uint8_t used = (uint8_t)((head - tx_tail) & (TX_SIZE - 1u));
    if ((uint16_t)used + len > TX_SIZE - 1u) {
        tx_dropped++;
        return false;
    }
    for (uint8_t i = 0; i < len; ++i) {
        tx_buf[head] = data[i];
        head = (uint8_t)((head + 1u) & (TX_SIZE - 1u));
    }
    tx_head = head;
    UCSR0B |= (1 << UDRIE0); /* the ISR clears it when the ring is empty */
    return true;
}

uint16_t uart_rx_overflows(void)
{
    uint16_t n;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = rx_overflows; }
    return n;
}

uint16_t uart_tx_dropped(void) { return tx_dropped; }
