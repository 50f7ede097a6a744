/*
 * Quadrature encoder logic (X4): the transition table the pin-change ISR
 * (encoder_isr.S) uses, a C decoder with the same behaviour for the host tests, and the
 * main loop's extension of the ISR's 16-bit count to a 32-bit position.
 * Pin state ab = (B << 1) | A. A leads B for positive motor rotation, so the positive
 * sequence is ab = 0 -> 1 -> 3 -> 2 -> 0 (docs/hardware.md).
 */
#ifndef AUGER_ENC_H
#define AUGER_ENC_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Table entry for a two-step jump (both pins changed): the direction is unknown, so the
 * transition is counted as illegal and the position is left alone. */
#define ENC_ILLEGAL ((int8_t)-128)

/* Index = (new ab << 2) | old ab, the order in which the ISR assembles it from PIND. */
#define ENC_INDEX(old_ab, new_ab) ((uint8_t)((((new_ab) & 3u) << 2) | ((old_ab) & 3u)))

extern const int8_t enc_transition_table[16];

/* The ISR's own table (encoder_isr.S, board.c): 256 bytes of flash, 256-aligned, indexed by
 * (new_ab << 2) | (old_ab << 6). The ISR gets new_ab << 2 as PIND & 0x0C and keeps it for
 * the next edge as old_ab << 6 with one `swap`, so the index costs no shifts. */
#define ENC_ISR_INDEX(old_ab, new_ab) ((uint8_t)((((new_ab) & 3u) << 2) | (((old_ab) & 3u) << 6)))

/* The same transitions as a formula (A = bit 0, B = bit 1): no change 0, both pins changed
 * ENC_ILLEGAL, else +1 when new A differs from old B. A constant expression, so the ISR's
 * flash table (board.c) is built from it at compile time; the host tests check that it
 * equals enc_transition_table entry for entry. */
#define ENC_DELTA(old_ab, new_ab)                                                              \
    ((((old_ab) ^ (new_ab)) & 3u) == 0u   ? 0                                                  \
     : (((old_ab) ^ (new_ab)) & 3u) == 3u ? ENC_ILLEGAL                                        \
     : ((((new_ab) & 1u) ^ (((old_ab) >> 1) & 1u)) ? 1 : -1))

/* Count change for one transition: +1, -1, 0, or ENC_ILLEGAL. */
int8_t enc_delta(uint8_t old_ab, uint8_t new_ab);

/* What the ISR keeps, modelled in C: the last pin state and two wrapping 16-bit counts. */
typedef struct {
    uint8_t ab;
    uint16_t count;
    uint16_t illegal;
} enc_decoder_t;

void enc_decoder_init(enc_decoder_t *d, uint8_t ab);
/* One pin-change interrupt that sampled pin state ab. */
void enc_decoder_step(enc_decoder_t *d, uint8_t ab);

/* 32-bit position from the ISR's 16-bit count; must be called at least once per 32767
 * counts (every 10 ms it sees at most a few thousand). */
typedef struct {
    uint16_t last_count;
    int32_t position_counts;
} enc_extend_t;

void enc_extend_init(enc_extend_t *x, uint16_t count);
int32_t enc_extend(enc_extend_t *x, uint16_t count);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_ENC_H */
