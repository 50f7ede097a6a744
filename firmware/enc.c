/* Quadrature encoder logic; see enc.h. */
#include "enc.h"

#include <string.h>

#define I ENC_ILLEGAL
/* Row = new ab, column = old ab. Positive steps: 0->1, 1->3, 3->2, 2->0. */
const int8_t enc_transition_table[16] = {
    /* new 0: old 0..3 */ 0, -1, +1, I,
    /* new 1 */ +1, 0, I, -1,
    /* new 2 */ -1, I, 0, +1,
    /* new 3 */ I, +1, -1, 0,
};
#undef I

int8_t enc_delta(uint8_t old_ab, uint8_t new_ab)
{
    return enc_transition_table[ENC_INDEX(old_ab, new_ab)];
}

void enc_decoder_init(enc_decoder_t *d, uint8_t ab)
{
    d->ab = (uint8_t)(ab & 3u);
    d->count = 0;
    d->illegal = 0;
}

void enc_decoder_step(enc_decoder_t *d, uint8_t ab)
{
    int8_t delta = enc_delta(d->ab, ab);
    d->ab = (uint8_t)(ab & 3u);
    if (delta == ENC_ILLEGAL) {
        d->illegal++;
    } else {
        /* Wrapping 16-bit arithmetic, exactly as the ISR's add/adc does. */
        d->count = (uint16_t)(d->count + (uint16_t)(int16_t)delta);
    }
}

void enc_extend_init(enc_extend_t *x, uint16_t count)
{
    x->last_count = count;
    x->position_counts = 0;
}

int32_t enc_extend(enc_extend_t *x, uint16_t count)
{
    uint16_t diff_u = (uint16_t)(count - x->last_count);
    int16_t diff;
    memcpy(&diff, &diff_u, sizeof diff); /* two's complement without implementation-defined casts */
    x->last_count = count;
    /* Wrap the 32-bit position too (unsigned arithmetic: no signed overflow). */
    uint32_t pos_u;
    memcpy(&pos_u, &x->position_counts, sizeof pos_u);
    pos_u += (uint32_t)(int32_t)diff;
    memcpy(&x->position_counts, &pos_u, sizeof pos_u);
    return x->position_counts;
}
