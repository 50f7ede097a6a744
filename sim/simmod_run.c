/* simmod's running: each module advanced to a target time in batches of instructions, on
 * worker threads (each advances its share of the modules to the same target), batch or paced
 * to the wall clock in 1 ms slices. */
#define _DEFAULT_SOURCE
#include "simmod_internal.h"

#include <math.h>
#include <stdio.h>

/* simavr 1.6 runs one instruction per avr_run unless run_cycle_limit allows more: then
 * avr_run_one goes on until the next cycle timer (avr_cycle_timer_register shortens the run
 * when an instruction schedules an earlier one), an interrupt or a sleep. The simulation is
 * the same instruction for instruction (module_advance puts a timer at every time it stops
 * at); the per-instruction round of timer checks and calls goes. A profiler's step hook
 * wants every instruction: then one at a time. avr_reset sets the limit back to 1. */
void simmod_set_run_batching(module_t *m)
{
	m->avr->run_cycle_limit = m->step_hook ? 1 : (avr_cycle_count_t)1 << 24;
}

/* A timer that does nothing: it ends an instruction run at a time the board stops at. */
static avr_cycle_count_t fence_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	(void)when;
	(void)param;
	return 0;
}

static void module_advance(module_t *m, double t_s)
{
	avr_t *avr = m->avr;
	avr_cycle_count_t target = (avr_cycle_count_t)(t_s * m->freq_hz);
	while (m->alive && avr->cycle < target) {
		avr_cycle_count_t stop = target < m->next_service ? target : m->next_service;
		avr_cycle_timer_register(avr, stop - avr->cycle, fence_timer, m);
		while (avr->cycle < stop) {
			if (m->step_hook) {
				simmod_step_info_t info;
				info.pc_before = avr->pc;
				info.cycle_before = avr->cycle;
				uint64_t slept = m->sleep_cycles;
				avr_run(avr);
				info.pc_after = avr->pc;
				info.cycle_after = avr->cycle;
				info.sleep_cycles = m->sleep_cycles - slept;
				info.sp_after = (uint16_t)(avr->data[REG_SPL] | (avr->data[REG_SPH] << 8));
				m->step_hook(m->step_hook_ctx, m->index, &info);
			} else {
				avr_run(avr);
			}
			int state = avr->state;
			if (state == cpu_Done || state == cpu_Crashed) {
				m->alive = 0;
				fprintf(stderr, "auger-sim: module %d stopped (%s) at %.6f s\n", m->index,
						state == cpu_Done ? "slept with interrupts off" : "crashed",
						(double)avr->cycle / m->freq_hz);
				return;
			}
			if (m->reset_seen) {
				simmod_module_after_reset(m);
				/* A watchdog reset (Optiboot's way to start the application) leaves
				 * simavr 1.6's watchdog enabled, so the application would be reset again
				 * and again: with a bootloader, redo it as a power-on reset. */
				if (m->foreign_reset && m->has_boot)
					simmod_module_reset(m, MCUSR_PORF);
			}
		}
		if (avr->cycle >= m->next_service) {
			simmod_uart_service(m);
			m->next_service += m->service_cycles;
		}
	}
}

static void advance_share(simmod_t *sim, int w, double t_s)
{
	for (int i = w; i < sim->count; i += sim->nthreads)
		module_advance(sim->mod[i], t_s);
}

static void *worker_main(void *arg)
{
	worker_arg_t *a = (worker_arg_t *)arg;
	simmod_t *sim = a->sim;
	unsigned seen = 0;
	pthread_mutex_lock(&sim->mu);
	for (;;) {
		while (sim->gen == seen && !sim->quit)
			pthread_cond_wait(&sim->go, &sim->mu);
		if (sim->quit)
			break;
		seen = sim->gen;
		double t = sim->target_s;
		pthread_mutex_unlock(&sim->mu);
		advance_share(sim, a->w, t);
		pthread_mutex_lock(&sim->mu);
		if (--sim->busy == 0)
			pthread_cond_signal(&sim->done);
	}
	pthread_mutex_unlock(&sim->mu);
	return NULL;
}

static void advance_all(simmod_t *sim, double t_s)
{
	if (sim->nthreads <= 1) {
		advance_share(sim, 0, t_s);
		return;
	}
	pthread_mutex_lock(&sim->mu);
	sim->target_s = t_s;
	sim->busy = sim->nthreads - 1;
	sim->gen++;
	pthread_cond_broadcast(&sim->go);
	pthread_mutex_unlock(&sim->mu);
	advance_share(sim, 0, t_s);
	pthread_mutex_lock(&sim->mu);
	while (sim->busy)
		pthread_cond_wait(&sim->done, &sim->mu);
	pthread_mutex_unlock(&sim->mu);
}

void simmod_threads_start(simmod_t *sim, int threads)
{
	sim->nthreads = threads;
	pthread_mutex_init(&sim->mu, NULL);
	pthread_cond_init(&sim->go, NULL);
	pthread_cond_init(&sim->done, NULL);
	for (int w = 1; w < sim->nthreads; w++) {
		worker_arg_t *a = &sim->args[w];
		a->sim = sim;
		a->w = w;
		if (pthread_create(&sim->th[w], NULL, worker_main, a) != 0) {
			sim->nthreads = w;
			break;
		}
	}
}

void simmod_threads_stop(simmod_t *sim)
{
	if (sim->nthreads > 1) {
		pthread_mutex_lock(&sim->mu);
		sim->quit = 1;
		pthread_cond_broadcast(&sim->go);
		pthread_mutex_unlock(&sim->mu);
		for (int w = 1; w < sim->nthreads; w++)
			pthread_join(sim->th[w], NULL);
	}
}

static double wall_since(const struct timespec *t0)
{
	struct timespec now;
	clock_gettime(CLOCK_MONOTONIC, &now);
	return (double)(now.tv_sec - t0->tv_sec) + 1e-9 * (double)(now.tv_nsec - t0->tv_nsec);
}

void simmod_step_to(simmod_t *sim, double t_s)
{
	if (t_s <= sim->t_s)
		return;
	if (!sim->cfg.realtime) {
		advance_all(sim, t_s);
		sim->t_s = t_s;
		simmod_uart_dispatch(sim);
		return;
	}
	if (!sim->wall_started) {
		clock_gettime(CLOCK_MONOTONIC, &sim->wall0);
		sim->wall0.tv_sec -= (time_t)sim->t_s; /* keep sim time and wall time aligned */
		sim->wall_started = 1;
	}
	while (sim->t_s < t_s) {
		double next = sim->t_s + REALTIME_SLICE_S;
		if (next > t_s)
			next = t_s;
		advance_all(sim, next);
		sim->t_s = next;
		simmod_uart_dispatch(sim);
		double ahead = next - wall_since(&sim->wall0);
		if (ahead > 0) {
			struct timespec d = { (time_t)ahead, (long)((ahead - floor(ahead)) * 1e9) };
			nanosleep(&d, NULL);
		}
	}
}

double simmod_time_s(const simmod_t *sim)
{
	return sim->t_s;
}

void simmod_set_step_hook(simmod_t *sim, int module, simmod_step_hook_t hook, void *ctx)
{
	module_t *m = sim->mod[module];
	m->step_hook = hook;
	m->step_hook_ctx = ctx;
	simmod_set_run_batching(m);
}
