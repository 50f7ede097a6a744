// auger-track: how well a robot log tracked its reference. For each log: RMS of the measured
// pose (external tracking: x_m, y_m, psi_rad) minus the reference (xd_m, yd_m, psid_rad) per
// DOF over the samples where both are present, and the position error at the last such sample.
//   auger-track LOG...
#include "auger/args.hpp"
#include "auger/log.hpp"

#include <cmath>
#include <cstdio>
#include <exception>

namespace {

double wrap_rad(double a) { return std::remainder(a, 2.0 * M_PI); }

}  // namespace

int main(int argc, char** argv)
{
    const auger::CommandLine cli{"auger-track", "LOG...",
                                 "The tracking error of robot logs: RMS of x, y, psi against the reference and the\n"
                                 "final position error, one Markdown table row per log.\n",
                                 {},
                                 "Exit 0: every log read; 1: a log unreadable or without both poses; 2: bad usage.\n"};
    auger::Args args;
    if (const int rc = cli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
    if (args.positional.empty()) {
        cli.print_usage(stderr);
        return 2;
    }
    std::printf("| log | samples | RMS x | RMS y | RMS psi | final position error |\n");
    std::printf("|---|---|---|---|---|---|\n");
    int rc = 0;
    for (const std::string& path : args.positional) {
        try {
            auger::RobotLogReader reader(path);
            auger::RobotSample s;
            double sx = 0, sy = 0, spsi = 0, final_m = NAN;
            long n = 0;
            while (reader.next(s)) {
                if (std::isnan(s.x_m) || std::isnan(s.xd_m) || std::isnan(s.psi_rad) || std::isnan(s.psid_rad))
                    continue;
                const double ex = s.x_m - s.xd_m, ey = s.y_m - s.yd_m, epsi = wrap_rad(s.psi_rad - s.psid_rad);
                sx += ex * ex;
                sy += ey * ey;
                spsi += epsi * epsi;
                final_m = std::hypot(ex, ey);
                ++n;
            }
            if (n == 0) {
                std::fprintf(stderr, "auger-track: %s: no sample with both a measured and a reference pose\n", path.c_str());
                rc = 1;
                continue;
            }
            std::printf("| %s | %ld | %.3f m | %.3f m | %.3f rad | %.3f m |\n", path.c_str(), n, std::sqrt(sx / double(n)),
                        std::sqrt(sy / double(n)), std::sqrt(spsi / double(n)), final_m);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "auger-track: %s\n", e.what());
            rc = 1;
        }
    }
    return rc;
}
