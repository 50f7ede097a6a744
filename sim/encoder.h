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
	/* counts added to the shaft's (angle / rad_per_count): non-zero after the pins were
	 * held, so that they follow the shaft from the count they were left at */
	double offset_counts;
	int held;                 /* encoder_hold: the pins ignore the shaft */
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
 * angle_rad and re-drive the pins. Ends a hold. */
void encoder_restart(encoder_t *e, double angle_rad);
/* For a bench that drives the pins itself (encoder_rate.h): the shaft's pending edges
 * are dropped and the pins stay where they are, whatever the shaft does, until
 * encoder_release. While held, encoder_step moves them one X4 count (dir > 0 up, else down). */
void encoder_hold(encoder_t *e);
void encoder_step(encoder_t *e, int dir);
/* Back to the shaft: the count stays where the pins were left and follows the shaft's motion
 * from shaft_angle_rad on (no jump on the pins). */
void encoder_release(encoder_t *e, double shaft_angle_rad);

#ifdef __cplusplus
}
#endif
#endif
