/*
 * encoder: simavr part for the motor's quadrature encoder. The board hands it the motor
 * shaft's trajectory step by step (encoder_move); it schedules one cycle timer at the
 * exact simulated time of each X4 edge and drives its two output IRQs (wired to PD2 = A,
 * PD3 = B). A leads B for positive rotation: A rises while B is low.
 */
#ifndef AUGER_SIM_ENCODER_H
#define AUGER_SIM_ENCODER_H

#include <stdint.h>

#include "sim_avr.h"
#include "sim_irq.h"

#ifdef __cplusplus
extern "C" {
#endif

enum {
	IRQ_ENCODER_A = 0,
	IRQ_ENCODER_B,
	IRQ_ENCODER_COUNT
};

#define ENCODER_MAX_PENDING 1024

typedef struct encoder_t {
	avr_irq_t *irq;
	avr_t *avr;
	double rad_per_count;     /* 2 pi / counts per revolution (X4) */
	int64_t count;            /* count shown on the pins now: the exact true count */
	int64_t target_count;     /* count once every pending edge has fired */
	avr_cycle_count_t edge_when[ENCODER_MAX_PENDING];
	int64_t edge_count[ENCODER_MAX_PENDING];
	unsigned head, pending;
	uint64_t edges;           /* edges driven since init */
	uint64_t overflows;       /* edges dropped because the queue was full */
	char ext_port;            /* port whose 'external' pin state follows A and B, or 0 */
	uint8_t ext_mask_a, ext_mask_b;
	/* counts added to the shaft's (angle / rad_per_count): non-zero after a forced run,
	 * so that the physical mode continues from the count the forced run left */
	double offset_counts;
	/* forced mode (encoder_force_rate): edges at an imposed rate, the shaft ignored */
	int forced;
	int forced_dir;           /* +1 counts up, -1 down */
	double forced_mean_cycles; /* mean interval between edges */
	double forced_jitter;     /* interval uniform in mean x [1 - j, 1 + j] */
	double forced_next_cycle; /* exact (fractional) time of the next edge */
	uint64_t rng_state;       /* xorshift64 state: deterministic per seed */
} encoder_t;

/* counts_per_rev: X4 counts per motor revolution (48 for 12 cycles). */
void encoder_init(avr_t *avr, encoder_t *e, int counts_per_rev);
/* Wire the outputs to the A and B pin IRQs and drive the current state. */
void encoder_attach(encoder_t *e, avr_irq_t *pin_a, avr_irq_t *pin_b);
/* Also hold the pins in the port's external state (AVR_IOCTL_IOPORT_SET_EXTERNAL):
 * simavr 1.6 otherwise reads a pin as high whenever the firmware writes PORTx with the
 * pin's pull-up on (the encoder's pull-ups), losing the encoder's low level. */
void encoder_drive_port(encoder_t *e, char port, int bit_a, int bit_b);
/* The shaft moves linearly from angle_from to angle_to between cycles from and to:
 * schedule an edge for every count boundary crossed. */
void encoder_move(encoder_t *e, avr_cycle_count_t from, avr_cycle_count_t to,
		double angle_from_rad, double angle_to_rad);
/* After an avr_reset (cycle timers cleared): drop pending edges, jump to the count of
 * angle_rad and re-drive the pins. Ends a forced run. */
void encoder_restart(encoder_t *e, double angle_rad);
/* Test and benchmark hook: drive the pins at edges_per_s (sign = direction) whatever the
 * shaft does. Intervals are uniform in mean x [1 - jitter, 1 + jitter] (jitter 0..1, 0 =
 * regular), drawn from a xorshift64 generator seeded with seed. edges_per_s = 0 stops
 * forcing and returns to the shaft: the count stays where the forced run left it and
 * follows the shaft's motion from shaft_angle_rad on (no jump on the pins). */
void encoder_force_rate(encoder_t *e, double edges_per_s, double jitter, uint64_t seed,
		double shaft_angle_rad);

#ifdef __cplusplus
}
#endif
#endif
