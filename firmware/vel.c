/* Velocity by position differencing; see vel.h. */
#include "vel.h"

#include <string.h>

void vel_init(vel_t *v, uint32_t counts_per_rev_x100, uint16_t period_ms)
{
    /* crpm = counts / (cpr_x100 / 100) / (period_ms / 60000 min) * 100 */
    v->crpm_per_count = 6.0e8f / ((float)counts_per_rev_x100 * (float)period_ms);
    vel_restart(v);
}

void vel_restart(vel_t *v)
{
    v->last_position = 0;
    v->primed = false;
}

int32_t vel_diff_counts(vel_t *v, int32_t position_counts)
{
    uint32_t pos_u;
    memcpy(&pos_u, &position_counts, sizeof pos_u);
    uint32_t diff_u = pos_u - v->last_position;
    bool primed = v->primed;
    v->last_position = pos_u;
    v->primed = true;
    if (!primed) return 0;
    int32_t diff;
    memcpy(&diff, &diff_u, sizeof diff);
    return diff;
}

int16_t vel_crpm_from_counts(const vel_t *v, int32_t counts)
{
    if (counts == 0) return 0; /* what the float path gives, without ~300 cycles of it */
    float crpm = (float)counts * v->crpm_per_count;
    if (crpm >= 32767.0f) return 32767;
    if (crpm <= -32767.0f) return -32767;
    return (int16_t)(crpm >= 0.0f ? crpm + 0.5f : crpm - 0.5f);
}

int16_t vel_update_crpm(vel_t *v, int32_t position_counts)
{
    return vel_crpm_from_counts(v, vel_diff_counts(v, position_counts));
}
