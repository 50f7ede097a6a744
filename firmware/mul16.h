/*
 * 16 x 16 -> 32-bit unsigned multiply. On the AVR gcc calls libgcc for it (__umulhisi3, or
 * __mulsi3's full 32 x 32 where it sees the operands as 32-bit values of known range: ~50
 * cycles with the nested calls); inline, the four hardware `mul`s are 18 cycles. The host
 * build (unit tests) uses the plain product.
 */
#ifndef AUGER_MUL16_H
#define AUGER_MUL16_H

#include <stdint.h>

static inline __attribute__((always_inline)) uint32_t mul_u16(uint16_t a, uint16_t b)
{
#ifdef __AVR__
    uint32_t r;
    uint8_t zero;
    __asm__("clr  %[z]          \n\t"
            "mul  %A[a], %A[b]  \n\t"
            "movw %A[r], r0     \n\t"
            "mul  %B[a], %B[b]  \n\t"
            "movw %C[r], r0     \n\t"
            "mul  %A[a], %B[b]  \n\t"
            "add  %B[r], r0     \n\t"
            "adc  %C[r], r1     \n\t"
            "adc  %D[r], %[z]   \n\t"
            "mul  %B[a], %A[b]  \n\t"
            "add  %B[r], r0     \n\t"
            "adc  %C[r], r1     \n\t"
            "adc  %D[r], %[z]   \n\t"
            "clr  __zero_reg__  \n\t"
            : [r] "=&r"(r), [z] "=&r"(zero)
            : [a] "r"(a), [b] "r"(b)
            : "r0");
    return r;
#else
    return (uint32_t)a * b;
#endif
}

#endif /* AUGER_MUL16_H */
