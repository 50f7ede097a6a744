/* Quadrature encoder part: edges at the exact simulated times, from cycle timers. */
#include "encoder.h"

#include <math.h>

#include "avr_ioport.h"
#include "sim_io.h"

static const char *encoder_irq_names[IRQ_ENCODER_COUNT] = {
	[IRQ_ENCODER_A] = ">encoder.a",
	[IRQ_ENCODER_B] = ">encoder.b",
};

/* X4 phase -> pins: 0 (A0 B0), 1 (A1 B0), 2 (A1 B1), 3 (A0 B1); counting up, A rises
 * while B is low. */
static int phase_a(int64_t count)
{
	int ph = (int)(count & 3);
	return ph == 1 || ph == 2;
}

static int phase_b(int64_t count)
{
	return (int)(count & 3) >= 2;
}

static void encoder_set_external(encoder_t *e, int a, int b)
{
	if (!e->ext_port)
		return;
	avr_ioport_external_t ext;
	ext.name = (unsigned long)e->ext_port;
	ext.mask = e->ext_mask_a | e->ext_mask_b;
	ext.value = (a ? e->ext_mask_a : 0u) | (b ? e->ext_mask_b : 0u);
	avr_ioctl(e->avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(e->ext_port), &ext);
}

static void encoder_drive(encoder_t *e, int64_t count)
{
	int a = phase_a(count), b = phase_b(count);
	encoder_set_external(e, a, b);
	if (a != phase_a(e->count))
		avr_raise_irq(e->irq + IRQ_ENCODER_A, a);
	if (b != phase_b(e->count))
		avr_raise_irq(e->irq + IRQ_ENCODER_B, b);
	e->count = count;
	e->edges++;
}

static avr_cycle_count_t encoder_edge_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)when;
	encoder_t *e = (encoder_t *)param;
	/* fire every edge due by now (a timer returned for the past would be dropped) */
	while (e->pending && e->edge_when[e->head] <= avr->cycle) {
		encoder_drive(e, e->edge_count[e->head]);
		e->head = (e->head + 1) % ENCODER_MAX_PENDING;
		e->pending--;
	}
	return e->pending ? e->edge_when[e->head] : 0;
}

static void encoder_push(encoder_t *e, avr_cycle_count_t when, int64_t count)
{
	if (e->pending == ENCODER_MAX_PENDING) {
		e->overflows++;
		return;
	}
	unsigned tail = (e->head + e->pending) % ENCODER_MAX_PENDING;
	if (e->pending) {
		unsigned last = (tail + ENCODER_MAX_PENDING - 1) % ENCODER_MAX_PENDING;
		if (when <= e->edge_when[last])
			when = e->edge_when[last] + 1;
	}
	if (when <= e->avr->cycle)
		when = e->avr->cycle + 1;
	e->edge_when[tail] = when;
	e->edge_count[tail] = count;
	e->target_count = count;
	if (e->pending++ == 0)
		avr_cycle_timer_register(e->avr, when - e->avr->cycle, encoder_edge_timer, e);
}

void encoder_move(encoder_t *e, avr_cycle_count_t from, avr_cycle_count_t to,
		double angle_from_rad, double angle_to_rad)
{
	if (e->held)
		return; /* someone else drives the pins (encoder_hold) */
	angle_from_rad += e->offset_counts * e->rad_per_count;
	angle_to_rad += e->offset_counts * e->rad_per_count;
	double da = angle_to_rad - angle_from_rad;
	if (da == 0 || to <= from)
		return;
	double span = (double)(to - from);
	int64_t c = e->target_count;
	if (da > 0) {
		while ((double)(c + 1) * e->rad_per_count <= angle_to_rad) {
			double f = ((double)(c + 1) * e->rad_per_count - angle_from_rad) / da;
			if (f < 0)
				f = 0;
			encoder_push(e, from + (avr_cycle_count_t)(f * span), c + 1);
			c++;
			if (e->pending == ENCODER_MAX_PENDING)
				break;
		}
	} else {
		while ((double)c * e->rad_per_count > angle_to_rad) {
			double f = ((double)c * e->rad_per_count - angle_from_rad) / da;
			if (f < 0)
				f = 0;
			encoder_push(e, from + (avr_cycle_count_t)(f * span), c - 1);
			c--;
			if (e->pending == ENCODER_MAX_PENDING)
				break;
		}
	}
}

void encoder_init(avr_t *avr, encoder_t *e, int counts_per_rev)
{
	e->avr = avr;
	e->irq = avr_alloc_irq(&avr->irq_pool, 0, IRQ_ENCODER_COUNT, encoder_irq_names);
	e->rad_per_count = 6.283185307179586 / counts_per_rev;
	e->count = e->target_count = 0;
	e->head = e->pending = 0;
	e->edges = e->overflows = 0;
	e->ext_port = 0;
	e->ext_mask_a = e->ext_mask_b = 0;
	e->offset_counts = 0;
	e->held = 0;
}

void encoder_drive_port(encoder_t *e, char port, int bit_a, int bit_b)
{
	e->ext_port = port;
	e->ext_mask_a = (uint8_t)(1u << bit_a);
	e->ext_mask_b = (uint8_t)(1u << bit_b);
	encoder_restart(e, e->rad_per_count * ((double)e->count - e->offset_counts));
}

void encoder_attach(encoder_t *e, avr_irq_t *pin_a, avr_irq_t *pin_b)
{
	avr_connect_irq(e->irq + IRQ_ENCODER_A, pin_a);
	avr_connect_irq(e->irq + IRQ_ENCODER_B, pin_b);
	encoder_restart(e, 0);
}

void encoder_restart(encoder_t *e, double angle_rad)
{
	avr_cycle_timer_cancel(e->avr, encoder_edge_timer, e);
	e->held = 0;
	e->head = e->pending = 0;
	int64_t c = (int64_t)floor(angle_rad / e->rad_per_count + e->offset_counts);
	e->count = e->target_count = c;
	/* a reset clears the port's view of the pins: force both levels through */
	int a = phase_a(c), b = phase_b(c);
	encoder_set_external(e, a, b);
	avr_raise_irq(e->irq + IRQ_ENCODER_A, !a);
	avr_raise_irq(e->irq + IRQ_ENCODER_A, a);
	avr_raise_irq(e->irq + IRQ_ENCODER_B, !b);
	avr_raise_irq(e->irq + IRQ_ENCODER_B, b);
}

/* ---- held: a bench drives the pins ---- */

void encoder_hold(encoder_t *e)
{
	avr_cycle_timer_cancel(e->avr, encoder_edge_timer, e);
	/* Pending shaft edges are dropped: the count stays at what the pins show now. */
	e->head = e->pending = 0;
	e->target_count = e->count;
	e->held = 1;
}

void encoder_step(encoder_t *e, int dir)
{
	encoder_drive(e, e->count + (dir > 0 ? 1 : -1));
	e->target_count = e->count;
}

void encoder_release(encoder_t *e, double shaft_angle_rad)
{
	encoder_hold(e);
	e->held = 0;
	/* Continue from the current count, in the middle of its cell: the shaft's next half
	 * count of motion either way moves the pins. */
	e->offset_counts = (double)e->count + 0.5 - shaft_angle_rad / e->rad_per_count;
}
