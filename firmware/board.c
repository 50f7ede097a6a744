/* Board layer: pins, Timer1 PWM, Timer2 tick, encoder interrupt, watchdog, sleep, stack. */
#include "board.h"

#include <avr/interrupt.h>
#include <avr/sleep.h> /* sleep_cpu */
#include <avr/wdt.h>
#include <util/atomic.h>

#include "enc.h"

/* Read by the simulator (docs/firmware.md): `used` and `externally_visible` keep the
 * name through -flto even though the firmware itself never reads it. */
__attribute__((used, externally_visible)) volatile uint16_t fw_stack_unused_bytes;

void board_init(void)
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

    /* Encoder: inputs with pull-ups, the table in RAM, the current state, then PCINT. */
    ENC_DDR &= (uint8_t)~((1 << ENC_A_BIT) | (1 << ENC_B_BIT));
    ENC_PORT |= (1 << ENC_A_BIT) | (1 << ENC_B_BIT);
    for (uint8_t i = 0; i < 16; ++i) enc_isr_table[i] = (uint8_t)enc_transition_table[i];
    enc_isr_count = 0;
    enc_isr_illegal = 0;
    __builtin_avr_delay_cycles(16); /* pull-ups charge the lines, PIND's synchroniser follows */
    enc_isr_prev = (uint8_t)((uint8_t)(uintptr_t)enc_isr_table | ((ENC_PIN & ENC_AB_MASK) >> 2));
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
    /* mag * 1000 / 10000 = OCR counts of PWM_TOP + 1 */
    uint16_t ocr = (uint16_t)((mag + 5u) / 10u);
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

void board_encoder_read(uint16_t *count, uint16_t *illegal)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        *count = enc_isr_count;
        *illegal = enc_isr_illegal;
    }
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

void board_idle(uint8_t last_tick)
{
    /* Encoder edges and transmitted bytes wake the CPU thousands of times a second but
     * give the main loop nothing to do: go back to sleep here until the tick moves, a byte
     * arrives or a TWI transaction ends. No cli() around the check (a window with
     * interrupts off right after another ISR would delay the encoder ISR past the next
     * edge at 200k edges/s): instead the ISRs that bring work (tick, UART RX, TWI end)
     * clear SE, which turns a `sleep` reached after the check into a no-op. */
    for (;;) {
        SMCR = SLEEP_SMCR_IDLE;
        uint8_t twi = twi_state;
        if (board_tick != last_tick || uart_rx_pending() || twi == TWI_ST_DONE || twi == TWI_ST_ERROR)
            break;
        sleep_cpu();
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
