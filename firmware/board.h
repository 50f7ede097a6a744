/*
 * The board layer's one header: every register, pin and vector the firmware touches
 * (docs/hardware.md is the pin map; the simulator wires the same pins), and the board
 * functions the main loop calls. Only board_*.c, encoder_isr.S and main.c include it.
 */
#ifndef AUGER_BOARD_H
#define AUGER_BOARD_H

#ifndef __ASSEMBLER__
#include <stdbool.h>
#include <stdint.h>
#endif

#include <avr/io.h>

/* ---- pins (docs/hardware.md) ---------------------------------------------------------- */
#define ENC_PORT PORTD
#define ENC_PIN PIND
#define ENC_DDR DDRD
#define ENC_A_BIT PD2 /* PCINT18 */
#define ENC_B_BIT PD3 /* PCINT19 */
#define ENC_PCMSK PCMSK2
#define ENC_PCIE PCIE2
#define ENC_PCINT_MASK ((1 << PCINT18) | (1 << PCINT19))
/* The ISR takes (PIND & ENC_AB_MASK) as new_ab << 2: A on bit 2, B on bit 3. */
#define ENC_AB_MASK 0x0C
#if ENC_A_BIT != 2 || ENC_B_BIT != 3
#error "encoder_isr.S assumes A on PD2 and B on PD3"
#endif

#define MOTOR_PWM_PORT PORTB
#define MOTOR_PWM_DDR DDRB
#define MOTOR_PWM_BIT PB1 /* OC1A */
#define MOTOR_DIR_PORT PORTB
#define MOTOR_DIR_DDR DDRB
#define MOTOR_DIR_BIT PB0
#define LED_PORT PORTB
#define LED_DDR DDRB
#define LED_BIT PB5

/* ---- timers ----------------------------------------------------------------------------- */
/* Timer1 fast PWM, TOP = ICR1: 16 MHz / (999 + 1) = 16 kHz. */
#define PWM_TOP 999u
/* Timer2 CTC: 16 MHz / 128 / (124 + 1) = 1 kHz. */
#define TICK_OCR 124u
#define TICK_VECT TIMER2_COMPA_vect
#define WDT_VECT WDT_vect
/* Watchdog: interrupt after 64 ms without wdt_reset, reset after 128 ms. */
#define WDT_PRESCALER_BITS (1 << WDP1)
#define WDT_MARKER0 0x5A
#define WDT_MARKER1 0xC3

/* ---- vectors ---------------------------------------------------------------------------- */
#define ENC_VECT PCINT2_vect
#define UART_RX_VECT USART_RX_vect
#define UART_UDRE_VECT USART_UDRE_vect
#define TWI_VECT TWI_vect

/* The assembly ISRs (encoder, tick, TWI, UART) save registers in GPIOR0..2 (1 cycle each
 * instead of a 2-cycle push) and SREG in ISR_REG_SREG (below). No ISR enables interrupts,
 * so they never nest and can share them; nothing else may use them. */
#define ISR_SAVE0 GPIOR0
#define ISR_SAVE1 GPIOR1
#define ISR_SAVE2 GPIOR2

/* Registers that belong to the assembly ISRs: the C code is compiled with -ffixed-r2 ..
 * -ffixed-r5 (firmware/Makefile), and every build runs check-isr-regs.sh, which fails if
 * any function of the image other than the ISRs and board_init / board_encoder_read names
 * them (libgcc and avr-libc are not compiled with those flags). */
#define ISR_REG_ENC_PREV r2 /* encoder: old ab << 6 */
#define ISR_REG_SREG r3     /* SREG while an ISR runs (they never nest) */
#define ISR_REG_ENC_LO r4   /* encoder: wrapping X4 count, low byte */
#define ISR_REG_ENC_HI r5   /* high byte */

/* TWI transaction states, shared by board_twi.c and twi_isr.S. */
#define TWI_ST_IDLE 0
#define TWI_ST_BUSY 1
#define TWI_ST_DONE 2
#define TWI_ST_ERROR 3

/* ---- UART --------------------------------------------------------------------------------- */
/* Ring sizes, powers of two (the ISRs wrap with a mask); no `u` suffix: uart_isr.S uses them. */
#define UART_RX_SIZE 64  /* 2.5 ms of input at 250000 baud; drained at the tick after input */
#define UART_TX_SIZE 128 /* four telemetry frames */
/* 250000 baud with U2X: UBRR = 16 MHz / (8 * 250000) - 1 = 7, exact. */
#define UART_UBRR 7u

/* Idle sleep mode with SE set; ISRs that give the main loop work clear SE (board_idle). */
#define SLEEP_SMCR_IDLE (1 << SE)

/* Stack painting pattern (encoder_isr.S fills free RAM with it at boot). */
#define STACK_PAINT 0xC5

#ifndef __ASSEMBLER__

/* ---- encoder_isr.S ---- */
extern const uint8_t enc_isr_table[256];   /* flash, 256-aligned, ENC_ISR_INDEX (enc.h) */
extern volatile uint16_t enc_isr_illegal;  /* wrapping illegal-transition count */
extern volatile uint8_t board_tick;        /* 1 kHz tick, wraps */
extern volatile uint8_t board_wake_tick;   /* the tick ISR wakes the loop at this tick */
extern uint8_t fw_reset_cause;             /* MCUSR at boot (.noinit, set in .init3) */
extern volatile uint8_t fw_wdt_marker[2];  /* set by the watchdog interrupt */

/* ---- board.c ---- */
void board_init(void);      /* pins, Timer1 PWM (motor braked), Timer2 tick, encoder */
/* Signed duty in 1/10000 of full scale; the sign drives DIR; 0 brakes. */
void board_motor_set(int16_t duty_x10000);
void board_encoder_read(uint16_t *count, uint16_t *illegal);
void board_led(bool on);
void board_wdt_start(void); /* interrupt-then-reset mode, 64 ms + 64 ms */
void board_wdt_reset(void); /* also re-arms the interrupt stage after a late reset */
/* Sleep until due_ms ticks after last_tick (1..127), a tick after a received byte, or the
 * end of a TWI transaction. */
void board_idle(uint8_t last_tick, uint8_t due_ms);
/* Unused stack in bytes: painted bytes above the end of .bss/.noinit that are still intact. */
uint16_t board_stack_unused(void);
extern volatile uint16_t fw_stack_unused_bytes;

/* ---- board_uart.c + uart_isr.S: rings written by one side each ---- */
extern volatile uint8_t uart_rx_buf[UART_RX_SIZE];
extern volatile uint8_t uart_rx_head, uart_rx_tail; /* ISR writes head, loop writes tail */
extern volatile uint16_t uart_rx_overflows_count;   /* ISR only; read atomically */
extern volatile uint8_t uart_rx_new; /* set by the RX ISR, cleared by the loop: wake at the tick */
extern uint8_t uart_tx_buf[UART_TX_SIZE]; /* loop writes [head, ...), ISR reads [tail, head) */
extern volatile uint8_t uart_tx_head, uart_tx_tail; /* loop writes head, ISR writes tail */
void uart_init(void);
/* Up to max received bytes into dst; returns how many (0 when the ring is empty). */
uint8_t uart_read_some(uint8_t *dst, uint8_t max);
/* Queue a whole frame or nothing: never blocks. False (and counted) if it did not fit. */
bool uart_write(const uint8_t *data, uint8_t len);
/* Room for len bytes in one piece at the ring's head, or NULL (then use uart_write): a frame
 * encoded in place and committed costs no copy (~280 cycles for a telemetry frame). */
uint8_t *uart_tx_claim(uint8_t len);
void uart_tx_commit(uint8_t len); /* after uart_tx_claim(len) and writing len bytes */
uint16_t uart_rx_overflows(void); /* ring full or hardware overrun, wraps */
uint16_t uart_tx_dropped(void);

/* ---- board_twi.c + twi_isr.S: one transaction at a time, interrupt-driven ---- */
extern volatile uint8_t twi_sla, twi_wleft, twi_rleft, twi_state;
extern const uint8_t *volatile twi_wptr;
extern uint8_t *volatile twi_rptr;
enum twi_status { TWI_IDLE = TWI_ST_IDLE, TWI_BUSY = TWI_ST_BUSY, TWI_DONE = TWI_ST_DONE,
                  TWI_ERROR = TWI_ST_ERROR };
void twi_init(void);
/* Write wlen bytes, then (repeated start) read rlen bytes into rbuf. The buffers must live
 * until the transaction ends. False if a transaction is already running. */
bool twi_start(uint8_t addr7, const uint8_t *wbuf, uint8_t wlen, uint8_t *rbuf, uint8_t rlen);
enum twi_status twi_status(void);
void twi_acknowledge(void); /* DONE/ERROR -> IDLE */
void twi_abort(void);       /* release the bus after a timeout */

/* ---- board_eeprom.c ---- */
void eeprom_read_image(uint16_t addr, uint8_t *data, uint8_t len); /* boot only: blocks */
/* Start writing len bytes (copied); written one byte per eeprom_poll while ready. */
void eeprom_write_start(uint16_t addr, const uint8_t *data, uint8_t len);
/* Call from the main loop; true while a write is in progress. */
bool eeprom_poll(void);

#endif /* __ASSEMBLER__ */

#endif /* AUGER_BOARD_H */
