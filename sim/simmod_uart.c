/* simmod's UART pump: input fed at the line rate and held while simavr's 63-byte FIFO is
 * full (docs/simulator.md "simavr 1.6 pitfalls handled"), output bytes stamped with their
 * simulated time, and the optional pty per module. */
#include "simmod_internal.h"

#include <stdlib.h>

#include "avr_uart.h"

static avr_cycle_count_t uart_byte_cycles(const module_t *m)
{
	const uint8_t *d = m->avr->data;
	uint32_t ubrr = d[REG_UBRR0L] | ((uint32_t)(d[REG_UBRR0H] & 0x0F) << 8);
	uint32_t per_bit = (ubrr + 1) * ((d[REG_UCSR0A] & UCSR0A_U2X0) ? 8u : 16u);
	return (avr_cycle_count_t)per_bit * UART_BITS_PER_BYTE;
}

static avr_cycle_count_t uart_feed_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	module_t *m = (module_t *)param;
	if (!m->in_len) {
		m->feeding = 0;
		return 0;
	}
	/* Hold while simavr's 63-byte FIFO is full. It signals room (XON) only when the
	 * firmware polls UCSR0A with the FIFO empty, so give up waiting after 64 byte times:
	 * by then a firmware that reads at all has drained it. */
	if (m->xoff && ++m->xoff_ticks < 64)
		return when + uart_byte_cycles(m);
	m->xoff = 0;
	m->xoff_ticks = 0;
	uint8_t b = m->in_buf[m->in_head];
	m->in_head = (m->in_head + 1) % IN_CAP;
	m->in_len--;
	avr_raise_irq(m->uart_irq + UART_IRQ_INPUT, b);
	return when + uart_byte_cycles(m);
}

void simmod_uart_queue(module_t *m, const uint8_t *data, size_t len)
{
	for (size_t i = 0; i < len && m->in_len < IN_CAP; i++) {
		m->in_buf[(m->in_head + m->in_len) % IN_CAP] = data[i];
		m->in_len++;
	}
	if (m->in_len && !m->feeding && m->alive) {
		m->feeding = 1;
		avr_cycle_timer_register(m->avr, 1, uart_feed_timer, m);
	}
}

static void uart_out_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	module_t *m = (module_t *)param;
	if (m->out_len == m->out_cap) {
		size_t cap = m->out_cap ? 2 * m->out_cap : 256;
		out_byte_t *o = realloc(m->out, cap * sizeof(*o));
		if (!o)
			return;
		m->out = o;
		m->out_cap = cap;
	}
	m->out[m->out_len].byte = (uint8_t)value;
	m->out[m->out_len].t_s = (double)m->avr->cycle / m->freq_hz;
	m->out_len++;
	if (m->has_pty) {
		if (m->pty_out_len == sizeof(m->pty_out)) {
			pty_bridge_write(&m->pty, m->pty_out, m->pty_out_len);
			m->pty_out_len = 0;
		}
		m->pty_out[m->pty_out_len++] = (uint8_t)value;
	}
}

static void uart_xon_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	(void)value;
	module_t *m = (module_t *)param;
	m->xoff = 0;
	m->xoff_ticks = 0;
}

static void uart_xoff_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	module_t *m = (module_t *)param;
	m->xoff = value != 0;
	m->xoff_ticks = 0;
}

void simmod_uart_attach(module_t *m)
{
	m->uart_irq = avr_io_getirq(m->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
	avr_irq_register_notify(m->uart_irq + UART_IRQ_OUTPUT, uart_out_hook, m);
	avr_irq_register_notify(m->uart_irq + UART_IRQ_OUT_XON, uart_xon_hook, m);
	avr_irq_register_notify(m->uart_irq + UART_IRQ_OUT_XOFF, uart_xoff_hook, m);
}

void simmod_uart_restart(module_t *m)
{
	if (m->in_len && m->alive) {
		m->feeding = 1;
		avr_cycle_timer_register(m->avr, 1, uart_feed_timer, m);
	}
}

void simmod_uart_service(module_t *m)
{
	if (!m->has_pty)
		return;
	if (m->pty_out_len) {
		pty_bridge_write(&m->pty, m->pty_out, m->pty_out_len);
		m->pty_out_len = 0;
	}
	if (pty_bridge_poll_open(&m->pty) && m->sim->cfg.reset_on_open)
		simmod_module_reset(m, MCUSR_EXTRF);
	uint8_t buf[256];
	size_t n = pty_bridge_read(&m->pty, buf, sizeof(buf));
	if (n)
		simmod_uart_queue(m, buf, n);
}

void simmod_uart_dispatch(simmod_t *sim)
{
	for (int i = 0; i < sim->count; i++) {
		module_t *m = sim->mod[i];
		if (sim->cb)
			for (size_t k = 0; k < m->out_len; k++)
				sim->cb(sim->cb_ctx, i, m->out[k].byte, m->out[k].t_s);
		m->out_len = 0;
	}
}

void simmod_set_uart_callback(simmod_t *sim, simmod_uart_cb_t cb, void *ctx)
{
	sim->cb = cb;
	sim->cb_ctx = ctx;
}

int simmod_uart_send(simmod_t *sim, int module, const uint8_t *data, size_t len)
{
	simmod_uart_queue(sim->mod[module], data, len);
	return 0;
}
