/* Velocity by position differencing; see vel.h. */
#include "vel.h"

#include "mul16.h"


void vel_init(vel_t *v, uint32_t counts_per_rev_x100, uint16_t period_ms)
{
    /* crpm = counts / (cpr_x100 / 100) / (period_ms / 60000 min) * 100, in 16.16. Float here
     * only (once per settings change); 24 bits of mantissa leave the factor's relative
     * error below 6e-8, far inside the rounding of the result. */
    float q16 = 6.0e8f * 65536.0f / ((float)counts_per_rev_x100 * (float)period_ms);
    /* Above 32767 crpm per count any motion reads as the clamp: no need to hold more. */
    v->crpm_per_count_q16 = q16 >= 32768.0f * 65536.0f ? 32768UL * 65536UL : (uint32_t)(q16 + 0.5f);
    vel_restart(v);
}

void vel_restart(vel_t *v)
{
    v->last_position = 0;
    v->primed = false;
}

int32_t vel_diff_counts(vel_t *v, int32_t position_counts)
{
    uint32_t pos_u = (uint32_t)position_counts; /* defined: modulo 2^32 */
    uint32_t diff_u = pos_u - v->last_position;
    bool primed = v->primed;
    v->last_position = pos_u;
    v->primed = true;
    if (!primed) return 0;
    /* back to signed without an implementation-defined conversion (nor a memcpy call) */
    return diff_u <= 0x7FFFFFFFu ? (int32_t)diff_u : -(int32_t)~diff_u - 1;
}

int16_t vel_crpm_from_counts(const vel_t *v, int32_t counts)
{
    if (counts == 0) return 0;
    bool neg = counts < 0;
    uint32_t mag = neg ? 0u - (uint32_t)counts : (uint32_t)counts;
    if (mag > 0xFFFFu) return neg ? -32767 : 32767;
    /* |counts| x factor in 16.16 as two 16x16 products: integer part times counts, plus
     * the fraction times counts rounded at bit 15 (half away from zero, as the float
     * path rounded). */
    uint16_t c = (uint16_t)mag;
    uint16_t whole = (uint16_t)(v->crpm_per_count_q16 >> 16);
    uint16_t frac = (uint16_t)(v->crpm_per_count_q16 & 0xFFFFu);
    uint32_t crpm = mul_u16(c, whole);
    if (crpm > 32767u) return neg ? -32767 : 32767;
    crpm += (mul_u16(c, frac) + 0x8000u) >> 16;
    if (crpm > 32767u) crpm = 32767u;
    return neg ? (int16_t)-(int16_t)crpm : (int16_t)crpm;
}

int16_t vel_update_crpm(vel_t *v, int32_t position_counts)
{
    return vel_crpm_from_counts(v, vel_diff_counts(v, position_counts));
}
