/* Board layer: pins, Timer1 PWM, Timer2 tick, encoder interrupt, watchdog, sleep, stack. */
#include "board.h"

#include <avr/interrupt.h>
#include <avr/pgmspace.h>
#include <avr/sleep.h> /* sleep_cpu */
#include <avr/wdt.h>
#include <util/atomic.h>

#include "enc.h"
#include "mul16.h"

/* Read by the simulator (docs/firmware.md): `used` and `externally_visible` keep the
 * name through -flto even though the firmware itself never reads it. */
__attribute__((used, externally_visible)) volatile uint16_t fw_stack_unused_bytes;

/* The encoder ISR's table (encoder_isr.S): 16 used entries of 256, at ENC_ISR_INDEX, from
 * the same transitions as enc_transition_table (ENC_DELTA, host-tested against it).
 * Flash, not RAM: lpm costs one cycle more than ld, but 256 aligned bytes of RAM would
 * cost up to 511. */
#define ENC_E(old_ab, new_ab) [ENC_ISR_INDEX(old_ab, new_ab)] = (uint8_t)ENC_DELTA(old_ab, new_ab)
__attribute__((used, externally_visible, aligned(256))) const uint8_t enc_isr_table[256] PROGMEM = {
    ENC_E(0, 0), ENC_E(0, 1), ENC_E(0, 2), ENC_E(0, 3), ENC_E(1, 0), ENC_E(1, 1),
    ENC_E(1, 2), ENC_E(1, 3), ENC_E(2, 0), ENC_E(2, 1), ENC_E(2, 2), ENC_E(2, 3),
    ENC_E(3, 0), ENC_E(3, 1), ENC_E(3, 2), ENC_E(3, 3),
};
#undef ENC_E

/* noinline, as board_encoder_read: the only C functions that name the ISRs' registers,
 * which check-isr-regs.sh allows by name. */
__attribute__((noinline)) void board_init(void)
{
    /* Motor first: PWM pin low (MD20A brakes), DIR low. */
    MOTOR_PWM_PORT &= (uint8_t)~(1 << MOTOR_PWM_BIT);
    MOTOR_PWM_DDR |= (1 << MOTOR_PWM_BIT);
    MOTOR_DIR_PORT &= (uint8_t)~(1 << MOTOR_DIR_BIT);
    MOTOR_DIR_DDR |= (1 << MOTOR_DIR_BIT);
    LED_DDR |= (1 << LED_BIT);

    /* Timer1: fast PWM, TOP = ICR1 (mode 14), no prescaler; OC1A connected only while the
     * duty is not 0 (in fast PWM OCR1A = 0 still gives a one-cycle spike every period).
     * TOP and compare first, clock last: simavr derives the period when TCCR1B starts the
     * timer and does not notice a later ICR1 write. */
    ICR1 = PWM_TOP;
    OCR1A = 0;
    TCCR1A = (1 << WGM11);
    TCCR1B = (1 << WGM13) | (1 << WGM12) | (1 << CS10);

    /* Timer2: CTC, /128, compare A every 125 counts = 1 kHz. */
    TCCR2A = (1 << WGM21);
    TCCR2B = (1 << CS22) | (1 << CS20);
    OCR2A = TICK_OCR;
    TIMSK2 = (1 << OCIE2A);

    /* Encoder: inputs with pull-ups, the current state, then PCINT. */
    ENC_DDR &= (uint8_t)~((1 << ENC_A_BIT) | (1 << ENC_B_BIT));
    ENC_PORT |= (1 << ENC_A_BIT) | (1 << ENC_B_BIT);
    enc_isr_illegal = 0;
    __builtin_avr_delay_cycles(16); /* pull-ups charge the lines, PIND's synchroniser follows */
    uint8_t prev = (uint8_t)((ENC_PIN & ENC_AB_MASK) << 4); /* old_ab << 6 */
    /* The ISR's registers (board.h): the previous state and a zero count. */
    __asm__ volatile("mov r2, %0\n\tclr r4\n\tclr r5" : : "r"(prev));
    ENC_PCMSK = ENC_PCINT_MASK;
    PCIFR = (1 << ENC_PCIE);
    PCICR |= (1 << ENC_PCIE);
}

void board_motor_set(int16_t duty_x10000)
{
    if (duty_x10000 == 0) {
        TCCR1A &= (uint8_t)~(1 << COM1A1); /* pin follows PORTB1 = 0: brake */
        /* Already 0 on the chip; in simavr the pin keeps the timer's last level until the
         * port is written. */
        MOTOR_PWM_PORT &= (uint8_t)~(1 << MOTOR_PWM_BIT);
        OCR1A = 0;
        return;
    }
    uint16_t mag = (uint16_t)(duty_x10000 < 0 ? -duty_x10000 : duty_x10000);
    if (mag > 10000u) mag = 10000u;
    /* mag * 1000 / 10000 = OCR counts of PWM_TOP + 1, rounded: x / 10 as (x * 6554) >> 16,
     * exact for x <= 16383 (checked exhaustively; mag + 5 <= 10005): a 16x16 multiply whose
     * high word is the quotient, instead of libgcc's 16-bit division (~200 cycles) or a
     * 19-bit shift (~140). */
    uint16_t ocr = (uint16_t)(mul_u16((uint16_t)(mag + 5u), 6554u) >> 16);
    if (ocr > PWM_TOP) ocr = PWM_TOP;
    if (duty_x10000 > 0) {
        MOTOR_DIR_PORT |= (1 << MOTOR_DIR_BIT);
    } else {
        MOTOR_DIR_PORT &= (uint8_t)~(1 << MOTOR_DIR_BIT);
    }
    /* Double-buffered: takes effect at the next period. (simavr 1.6 ignores OCR writes in
     * this mode; the simulator's sim/pwm_ocr_fix.c applies them, not the firmware.) */
    OCR1A = ocr;
    TCCR1A |= (1 << COM1A1);
}

__attribute__((noinline)) void board_encoder_read(uint16_t *count, uint16_t *illegal)
{
    uint16_t c;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        __asm__ volatile("mov %A0, r4\n\tmov %B0, r5" : "=r"(c)); /* the ISR's count (board.h) */
        *illegal = enc_isr_illegal;
    }
    *count = c;
}

void board_led(bool on)
{
    if (on) {
        LED_PORT |= (1 << LED_BIT);
    } else {
        LED_PORT &= (uint8_t)~(1 << LED_BIT);
    }
}

void board_wdt_start(void)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        wdt_reset();
        WDTCSR = (1 << WDCE) | (1 << WDE); /* timed sequence: next write within 4 cycles */
        WDTCSR = (1 << WDIE) | (1 << WDE) | WDT_PRESCALER_BITS;
    }
}

void board_wdt_reset(void)
{
    wdt_reset();
    /* The hardware clears WDIE when the interrupt stage fires; re-arm it so that a later
     * hang still leaves its marker. Setting WDIE needs no timed sequence. */
    if (!(WDTCSR & (1 << WDIE))) WDTCSR |= (1 << WDIE);
}

void board_idle(uint8_t last_tick, uint8_t due_ms)
{
    /* Ticks, encoder edges and transmitted bytes wake the CPU thousands of times a second,
     * but the loop has work only at the ticks it asked for (due_ms: the next INA219 cycle,
     * control step or command timeout), at the tick after a byte arrived (the RX ring holds
     * 2.5 ms) and at the end of a TWI transaction. The tick ISR and the TWI ISR clear SE
     * when they bring that work. So: set SE, look once for work that came before, then
     * sleep while SE stays set; a wake-up that brings nothing costs the `in`, a skipping
     * `sbrs` and the next `sleep` (4 cycles, the loop below unrolled). No cli() around the
     * check (a window with interrupts off right after another ISR would delay the encoder
     * ISR past the next edge at 200k edges/s): an ISR between the check and `sleep` clears
     * SE, which makes that `sleep` a no-op and ends the loop. */
    board_wake_tick = (uint8_t)(last_tick + due_ms);
    SMCR = SLEEP_SMCR_IDLE;
    uint8_t elapsed = (uint8_t)(board_tick - last_tick);
    uint8_t twi = twi_state;
    if (elapsed < due_ms && !(elapsed != 0 && uart_rx_new) && twi != TWI_ST_DONE && twi != TWI_ST_ERROR) {
        /* Unrolled: no jump back on every wake-up (5 cycles -> 4). */
        for (;;) {
#define SLEEP_WHILE_SE                         \
    sleep_cpu();                               \
    if (!(SMCR & (1 << SE))) break;
            SLEEP_WHILE_SE SLEEP_WHILE_SE SLEEP_WHILE_SE SLEEP_WHILE_SE
            SLEEP_WHILE_SE SLEEP_WHILE_SE SLEEP_WHILE_SE SLEEP_WHILE_SE
#undef SLEEP_WHILE_SE
        }
    }
    SMCR = 0;
}

extern uint8_t __heap_start;

uint16_t board_stack_unused(void)
{
    const volatile uint8_t *p = &__heap_start;
    uint16_t n = 0;
    while (p < (const volatile uint8_t *)RAMEND && *p == STACK_PAINT) {
        ++p;
        ++n;
    }
    return n;
}
