/* INA219 on simavr's TWI. */
#include "ina219.h"

#include "avr_twi.h"
#include "sim_io.h"
#include "sim_time.h"

static const char *ina219_irq_names[IRQ_INA219_COUNT] = {
	[IRQ_INA219_TWI_IN] = "32<ina219.in",
	[IRQ_INA219_TWI_OUT] = "32>ina219.out",
};

static avr_cycle_count_t ina219_conversion_timer(avr_t *avr, avr_cycle_count_t when,
		void *param)
{
	(void)avr;
	ina219_t *p = (ina219_t *)param;
	unsigned mode = ina219_regs_mode(&p->regs);
	if (mode == 0 || mode == 4)
		return 0;
	double shunt_v = p->last_shunt_v, bus_v = p->last_bus_v;
	if (p->sum_s > 0) {
		shunt_v = p->sum_shunt_v_s / p->sum_s;
		bus_v = p->sum_bus_v_s / p->sum_s;
	}
	p->sum_shunt_v_s = p->sum_bus_v_s = p->sum_s = 0;
	ina219_regs_convert(&p->regs, shunt_v, bus_v);
	if (mode < 4)
		return 0; /* triggered: one conversion per configuration write */
	return when + avr_usec_to_cycles(p->avr,
			(uint32_t)(ina219_regs_conversion_time_s(&p->regs) * 1e6 + 0.5));
}

void ina219_start(ina219_t *p)
{
	avr_cycle_timer_cancel(p->avr, ina219_conversion_timer, p);
	p->sum_shunt_v_s = p->sum_bus_v_s = p->sum_s = 0;
	unsigned mode = ina219_regs_mode(&p->regs);
	if (mode == 0 || mode == 4)
		return;
	avr_cycle_timer_register_usec(p->avr,
			(uint32_t)(ina219_regs_conversion_time_s(&p->regs) * 1e6 + 0.5),
			ina219_conversion_timer, p);
}

static void ina219_reply(ina219_t *p, uint8_t cond, uint8_t addr, uint8_t data)
{
	avr_raise_irq(p->irq + IRQ_INA219_TWI_OUT, avr_twi_irq_msg(cond, addr, data));
}

static void ina219_twi_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	ina219_t *p = (ina219_t *)param;
	avr_twi_msg_irq_t v;
	v.u.v = value;

	if (v.u.twi.msg & TWI_COND_STOP)
		p->selected = 0;
	if (v.u.twi.msg & TWI_COND_START) {
		/* the address field is SLA+R/W */
		p->selected = (v.u.twi.addr >> 1) == p->addr7;
		if (!p->selected)
			return;
		p->reading = v.u.twi.addr & 1;
		p->byte_index = 0;
		p->transactions++;
		ina219_reply(p, TWI_COND_ACK, v.u.twi.addr, 1);
		return;
	}
	if (!p->selected)
		return;
	if (v.u.twi.msg & TWI_COND_WRITE) {
		uint8_t b = v.u.twi.data;
		if (p->byte_index == 0) {
			p->regs.pointer = b;
		} else if (p->byte_index == 1) {
			p->latch = (uint16_t)(b << 8);
		} else if (p->byte_index == 2) {
			p->latch |= b;
			if (ina219_regs_write(&p->regs, p->regs.pointer, p->latch))
				ina219_start(p);
		}
		p->byte_index++;
		ina219_reply(p, TWI_COND_ACK, v.u.twi.addr, 1);
	} else if (v.u.twi.msg & TWI_COND_READ) {
		/* the pointer stays: a long read repeats the register */
		if ((p->byte_index & 1) == 0)
			p->latch = ina219_regs_read(&p->regs, p->regs.pointer);
		uint8_t b = (p->byte_index & 1) ? (uint8_t)(p->latch & 0xFF) : (uint8_t)(p->latch >> 8);
		p->byte_index++;
		ina219_reply(p, TWI_COND_READ, v.u.twi.addr, b);
	}
}

void ina219_init(avr_t *avr, ina219_t *p, uint8_t addr7, double shunt_ohm)
{
	p->avr = avr;
	p->irq = avr_alloc_irq(&avr->irq_pool, 0, IRQ_INA219_COUNT, ina219_irq_names);
	p->addr7 = addr7;
	p->shunt_ohm = shunt_ohm;
	ina219_regs_reset(&p->regs);
	p->selected = p->reading = 0;
	p->byte_index = 0;
	p->latch = 0;
	p->sum_shunt_v_s = p->sum_bus_v_s = p->sum_s = 0;
	p->last_shunt_v = p->last_bus_v = 0;
	p->transactions = 0;
	avr_irq_register_notify(p->irq + IRQ_INA219_TWI_IN, ina219_twi_hook, p);
}

void ina219_attach(ina219_t *p, uint32_t twi_index)
{
	avr_connect_irq(p->irq + IRQ_INA219_TWI_OUT,
			avr_io_getirq(p->avr, AVR_IOCTL_TWI_GETIRQ(twi_index), TWI_IRQ_INPUT));
	avr_connect_irq(avr_io_getirq(p->avr, AVR_IOCTL_TWI_GETIRQ(twi_index), TWI_IRQ_OUTPUT),
			p->irq + IRQ_INA219_TWI_IN);
	ina219_start(p);
}

void ina219_sample(ina219_t *p, double current_a, double bus_v, double dt_s)
{
	double shunt_v = current_a * p->shunt_ohm;
	p->last_shunt_v = shunt_v;
	p->last_bus_v = bus_v;
	p->sum_shunt_v_s += shunt_v * dt_s;
	p->sum_bus_v_s += bus_v * dt_s;
	p->sum_s += dt_s;
}

void ina219_power_on_reset(ina219_t *p)
{
	ina219_regs_reset(&p->regs);
	p->selected = 0;
	ina219_start(p);
}
