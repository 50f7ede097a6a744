/*
 * Current foldback: between foldback_ma and the overcurrent trip the output is derated
 * linearly, from full at foldback_ma to zero at the trip, so a sustained overload runs at
 * reduced torque instead of tripping. The INA219 measures the pack current, which follows
 * the duty within a control period, so the derating cannot act as a plain function of the
 * last reading: through the motor's steep current-versus-duty curve (at a locked rotor
 * about 16 A per unit of u at 18 V) that sampled loop would swing between zero and full
 * output. The limit therefore moves towards the derating of each reading by a bounded step
 * per control period (foldback.c), and halves at once only at the trip: the current settles
 * where the derating meets the load. Called by the control step; the limit is the
 * PID's output clamp (so it cannot wind up either).
 */
#ifndef AUGER_FOLDBACK_H
#define AUGER_FOLDBACK_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    uint16_t start_ma;     /* 0: no foldback */
    uint16_t trip_ma;      /* the overcurrent limit */
    uint32_t inv_band_q24; /* 2^24 / (trip_ma - start_ma) */
    int32_t limit_q27;     /* output limit, Q27 of the rated voltage (PID_U_ONE = none) */
    bool halved;           /* the previous period halved the limit */
} foldback_t;

/* start_ma 0 or below trip_ma (settings_validate); resets the limit. */
void foldback_configure(foldback_t *f, uint16_t start_ma, uint16_t trip_ma);
/* Full output again (the motor was stopped). */
void foldback_reset(foldback_t *f);
/* One control period with the latest current reading and the output of the previous period
 * (Q27); returns the output limit (Q27). */
int32_t foldback_update(foldback_t *f, int16_t current_ma, int32_t u_q27);
/* The limit is below full output. */
bool foldback_active(const foldback_t *f);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_FOLDBACK_H */
