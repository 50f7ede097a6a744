// Benchmark: share of corrupted frames accepted with an XOR byte versus auger's CRC-16.
// Usage: proto_corruption [TRIALS_PER_ROW]   (docs/protocol.md records its output)
#include "corruption.hpp"

#include <cstdio>
#include <cstdlib>

using namespace auger::test;

int main(int argc, char** argv)
{
    long trials = argc > 1 ? std::atol(argv[1]) : 1000000;
    if (trials <= 0) {
        std::fprintf(stderr, "proto_corruption: TRIALS must be a positive integer, got '%s'\n", argv[1]);
        return 2;
    }
    std::printf("| damage (after the start bytes) | trials | accepted with XOR byte | accepted with CRC-16 |\n");
    std::printf("|---|---|---|---|\n");
    auto print = [](const CorruptionRow& r) {
        std::printf("| %s | %ld | %ld (%.3f %%) | %ld (%.4f %%) |\n", r.damage.c_str(), r.trials,
                    r.xor_accepted, 100.0 * double(r.xor_accepted) / double(r.trials), r.crc_accepted,
                    100.0 * double(r.crc_accepted) / double(r.trials));
    };
    for (int k = 1; k <= 4; ++k) print(measure_flips(k, trials, 1000 + k));
    print(measure_bursts(2, 8, trials, 2001));
    print(measure_bursts(9, 16, trials, 2002));
    print(measure_bursts(17, 32, trials, 2003));
    return 0;
}
