/*
 * Interrupt-driven TWI master, one transaction at a time (the interrupt is twi_isr.S).
 * The caller times out stuck transactions (twi_abort); nothing here waits.
 */
#include "board.h"

#include <util/atomic.h>

#include "config.h"

void twi_init(void)
{
    /* Internal pull-ups are weak but harmless; the INA219 board has its own. */
    PORTC |= (1 << PC4) | (1 << PC5);
    TWSR = 0; /* prescaler 1 */
    TWBR = (uint8_t)((F_CPU / TWI_SCL_HZ - 16u) / 2u); /* 12 for 400 kHz */
    TWCR = (1 << TWEN);
    twi_state = TWI_ST_IDLE;
}

bool twi_start(uint8_t addr7, const uint8_t *wbuf, uint8_t wlen, uint8_t *rbuf, uint8_t rlen)
{
    if (twi_state == TWI_ST_BUSY) return false;
    twi_sla = (uint8_t)(addr7 << 1);
    twi_wptr = wbuf;
    twi_wleft = wlen;
    twi_rptr = rbuf;
    twi_rleft = rlen;
    twi_state = TWI_ST_BUSY;
    TWCR = (1 << TWINT) | (1 << TWEN) | (1 << TWIE) | (1 << TWSTA);
    return true;
}

enum twi_status twi_status(void) { return (enum twi_status)twi_state; }

void twi_acknowledge(void)
{
    if (twi_state != TWI_ST_BUSY) twi_state = TWI_ST_IDLE;
}

void twi_abort(void)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        TWCR = 0; /* drop the bus; re-enabling resets the TWI state machine */
        TWCR = (1 << TWEN);
        twi_state = TWI_ST_IDLE;
    }
}
