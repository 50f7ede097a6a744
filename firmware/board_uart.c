/* Interrupt-driven USART0 at 250000 baud with ring buffers both ways; never blocks. The
 * interrupt handlers are in uart_isr.S. */
#include "board.h"

#include <string.h>
#include <util/atomic.h>

volatile uint8_t uart_rx_buf[UART_RX_SIZE];
volatile uint8_t uart_rx_head, uart_rx_tail;
volatile uint16_t uart_rx_overflows_count;
volatile uint8_t uart_rx_new;
/* Not volatile: only the loop writes it and the ISR (assembly) reads it; the compiler
 * barrier in uart_write orders the copy before the new head is published. */
__attribute__((aligned(UART_TX_SIZE))) uint8_t uart_tx_buf[UART_TX_SIZE];
volatile uint8_t uart_tx_head, uart_tx_tail;
static uint16_t tx_dropped;

void uart_init(void)
{
    UCSR0A = (1 << U2X0); /* before UBRR (simavr computes the baud rate on the UBRR write) */
    UBRR0H = (uint8_t)(UART_UBRR >> 8);
    UBRR0L = (uint8_t)(UART_UBRR & 0xFFu);
    UCSR0C = (1 << UCSZ01) | (1 << UCSZ00); /* 8N1 */
    UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
}

/* n > 0 bytes from src to dst: ld X+, st Z+, dec, brne (7 cycles a byte; gcc's loop over
 * the volatile ring indexes it without post-increment: 12). Returns dst after the copy. */
static inline __attribute__((always_inline)) uint8_t *copy_from_ring(uint8_t *dst, const volatile uint8_t *src,
                                                                    uint8_t n)
{
    __asm__ __volatile__("1: ld   __tmp_reg__, X+ \n\t"
                         "   st   Z+, __tmp_reg__ \n\t"
                         "   dec  %[n]            \n\t"
                         "   brne 1b              \n\t"
                         : [n] "+r"(n), "+x"(src), "+z"(dst)
                         :
                         : "memory");
    return dst;
}

uint8_t uart_read_some(uint8_t *dst, uint8_t max)
{
    uint8_t tail = uart_rx_tail;
    uint8_t n = (uint8_t)((uart_rx_head - tail) & (UART_RX_SIZE - 1u));
    if (n > max) n = max;
    if (n == 0) return 0;
    /* Up to the ring's end, then from its start (instead of masking the tail per byte). */
    uint8_t first = (uint8_t)(UART_RX_SIZE - tail);
    if (first > n) first = n;
    dst = copy_from_ring(dst, uart_rx_buf + tail, first);
    if (n != first) copy_from_ring(dst, uart_rx_buf, (uint8_t)(n - first));
    uart_rx_tail = (uint8_t)((tail + n) & (UART_RX_SIZE - 1u));
    return n;
}

bool uart_write(const uint8_t *data, uint8_t len)
{
    uint8_t head = uart_tx_head;
    uint8_t used = (uint8_t)((head - uart_tx_tail) & (UART_TX_SIZE - 1u));
    if ((uint16_t)used + len > UART_TX_SIZE - 1u) {
        tx_dropped++;
        return false;
    }
    /* At most two contiguous pieces (before and after the wrap), copied by memcpy: the
     * byte-by-byte loop with a masked index cost ~550 cycles per telemetry frame. */
    uint8_t first = (uint8_t)(UART_TX_SIZE - head);
    if (first > len) first = len;
    memcpy(&uart_tx_buf[head], data, first);
    memcpy(&uart_tx_buf[0], data + first, (uint8_t)(len - first));
    __asm__ __volatile__("" ::: "memory"); /* the bytes are in the ring before head moves */
    uart_tx_head = (uint8_t)((head + len) & (UART_TX_SIZE - 1u));
    UCSR0B |= (1 << UDRIE0); /* the ISR clears it when the ring is empty */
    return true;
}

uint8_t *uart_tx_claim(uint8_t len)
{
    uint8_t head = uart_tx_head;
    if ((uint16_t)head + len > UART_TX_SIZE && head == uart_tx_tail) {
        /* Empty (the usual case: a telemetry frame leaves in 1.3 ms of its 10): start over
         * at the front so that the frame fits in one piece. The ISR has masked itself and
         * reads tail == head; both move together, with interrupts off. */
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
        {
            if (uart_tx_head == uart_tx_tail) uart_tx_head = uart_tx_tail = 0;
        }
        head = uart_tx_head;
    }
    uint8_t used = (uint8_t)((head - uart_tx_tail) & (UART_TX_SIZE - 1u));
    if ((uint16_t)used + len > UART_TX_SIZE - 1u || (uint16_t)head + len > UART_TX_SIZE) return 0;
    return &uart_tx_buf[head];
}

void uart_tx_commit(uint8_t len)
{
    __asm__ __volatile__("" ::: "memory"); /* the bytes are in the ring before head moves */
    uart_tx_head = (uint8_t)((uart_tx_head + len) & (UART_TX_SIZE - 1u));
    UCSR0B |= (1 << UDRIE0);
}

uint16_t uart_rx_overflows(void)
{
    uint16_t n;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = uart_rx_overflows_count; }
    return n;
}

uint16_t uart_tx_dropped(void) { return tx_dropped; }
