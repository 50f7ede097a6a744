// auger-module: identify a motor module and read or write its settings (EEPROM) through the
// protocol's CONFIG frame. `make flash ID=n` uses it after avrdude, since Optiboot cannot
// write EEPROM.
//
//   auger-module PORT identify
//   auger-module PORT show
//   auger-module PORT set KEY=VALUE...     keys: see usage()
//   options: --baud N (default 250000), --timeout S (identity wait, default 4)
#include "auger/args.hpp"
#include "module_adapter.hpp"
#include "module_link.hpp"
#include "status_text.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

using auger::io::ModuleLink;

namespace {

const auger::CommandLine kCli{
    "auger-module", "[OPTIONS] PORT identify|show|set KEY=VALUE...",
    "One motor module over its serial port: its identity, its settings, new settings (CONFIG).\n",
    {{"--baud", "N", "the port's rate (default 250000)"},
     {"--timeout", "S", "wait this long for the identity (default 4 s: a reset into the bootloader)"}},
    "set keys (units in the name):\n"
    "  id=0..255  dir=+1|-1  counts_per_rev=COUNTS (X4 counts per screw turn)\n"
    "  kp=X ki=X kd=X (velocity PID, docs/firmware.md units)\n"
    "  omega_max_rpm=X  overcurrent_a=X  overcurrent_samples=N\n"
    "  undervoltage_v=X  undervoltage_hyst_v=X  motor_rated_v=X  cmd_timeout_ms=N\n"
    "  foldback_a=X (0: off)  stall_current_a=X (0: off)  stall_time_ms=N\n"
    "  telemetry_period_ms=10|20|50|100\n"
    "Exit 0: done; 1: the module failed or refused; 2: bad usage.\n"};

void usage(FILE* out) { kCli.print_usage(out); }

[[noreturn]] void bad_arg(const std::string& arg, const std::string& why)
{
    throw std::invalid_argument("argument '" + arg + "': " + why);
}

double number(const std::string& arg, const std::string& text)
{
    double x = 0;
    if (!auger::decimal_number(text, x)) bad_arg(arg, "'" + text + "' is not a number");
    return x;
}

template <typename T>
T in_range(const std::string& arg, double x, double lo, double hi)
{
    if (x < lo || x > hi) {
        char range[64];
        std::snprintf(range, sizeof range, "must be within %g .. %g", lo, hi);
        bad_arg(arg, range);
    }
    return T(std::llround(x));
}

void apply(proto_config_t& c, const std::string& arg)
{
    auto eq = arg.find('=');
    if (eq == std::string::npos) bad_arg(arg, "expected KEY=VALUE");
    const std::string key = arg.substr(0, eq);
    const double x = number(arg, arg.substr(eq + 1));
    const std::map<std::string, std::function<void()>> keys = {
        {"id", [&] { c.module_id = in_range<uint8_t>(arg, x, 0, 255); }},
        {"dir", [&] {
             if (x != 1 && x != -1) bad_arg(arg, "must be +1 or -1");
             c.dir_sign = int8_t(x);
         }},
        {"counts_per_rev", [&] { c.counts_per_rev_x100 = in_range<uint32_t>(arg, x * 100, 1, 4294967295.0); }},
        {"kp", [&] { c.kp = float(x); }},
        {"ki", [&] { c.ki = float(x); }},
        {"kd", [&] { c.kd = float(x); }},
        {"omega_max_rpm", [&] { c.omega_max_crpm = in_range<uint16_t>(arg, x * 100, 0, 32767); }},
        {"overcurrent_a", [&] { c.overcurrent_ma = in_range<uint16_t>(arg, x * 1000, 1, 65535); }},
        {"overcurrent_samples", [&] { c.overcurrent_samples = in_range<uint8_t>(arg, x, 1, 255); }},
        {"undervoltage_v", [&] { c.undervoltage_mv = in_range<uint16_t>(arg, x * 1000, 0, 65535); }},
        {"undervoltage_hyst_v", [&] { c.undervoltage_hyst_mv = in_range<uint16_t>(arg, x * 1000, 0, 65535); }},
        {"motor_rated_v", [&] { c.motor_rated_mv = in_range<uint16_t>(arg, x * 1000, 1, 65535); }},
        {"cmd_timeout_ms", [&] { c.cmd_timeout_ms = in_range<uint16_t>(arg, x, 1, 65535); }},
        {"foldback_a", [&] { c.foldback_ma = in_range<uint16_t>(arg, x * 1000, 0, 65535); }},
        {"stall_current_a", [&] { c.stall_current_ma = in_range<uint16_t>(arg, x * 1000, 0, 32767); }},
        {"stall_time_ms", [&] { c.stall_time_ms = in_range<uint16_t>(arg, x, 10, 2550); }},
        {"telemetry_period_ms", [&] {
             if (x != 10 && x != 20 && x != 50 && x != 100) bad_arg(arg, "must be 10, 20, 50 or 100");
             c.telemetry_period_ms = uint8_t(x);
         }},
    };
    auto it = keys.find(key);
    if (it == keys.end()) bad_arg(arg, "unknown key '" + key + "'");
    it->second();
}

void print_identity(const std::string& port, const proto_identity_t& id)
{
    std::printf("%s: module %u, firmware %u.%u.%u, protocol %u, settings from %s, last reset: %s\n",
                port.c_str(), id.module_id, id.fw_major, id.fw_minor, id.fw_patch, id.protocol_version,
                auger::io::settings_origin_text(id.flags).c_str(), auger::io::reset_cause_text(id.reset_cause).c_str());
}

void print_config(const proto_config_t& c)
{
    std::printf("id=%u dir=%+d counts_per_rev=%.2f kp=%g ki=%g kd=%g omega_max_rpm=%.2f "
                "overcurrent_a=%.3f overcurrent_samples=%u undervoltage_v=%.3f "
                "undervoltage_hyst_v=%.3f motor_rated_v=%.3f cmd_timeout_ms=%u foldback_a=%.3f "
                "stall_current_a=%.3f stall_time_ms=%u telemetry_period_ms=%u\n",
                c.module_id, c.dir_sign, c.counts_per_rev_x100 / 100.0, double(c.kp), double(c.ki),
                double(c.kd), auger::io::rpm_from_crpm(c.omega_max_crpm), c.overcurrent_ma / 1000.0,
                c.overcurrent_samples, c.undervoltage_mv / 1000.0, c.undervoltage_hyst_mv / 1000.0,
                c.motor_rated_mv / 1000.0, c.cmd_timeout_ms, c.foldback_ma / 1000.0, c.stall_current_ma / 1000.0,
                c.stall_time_ms, c.telemetry_period_ms);
}

}  // namespace

int main(int argc, char** argv)
{
    std::vector<std::string> args;
    unsigned baud = ModuleLink::kDefaultBaud;
    double timeout_s = 4.0;
    try {
        auger::Args opts;
        if (const int rc = kCli.parse_or_answer(argc, argv, opts); rc >= 0) return rc;
        if (opts.has("--baud"))
            baud = in_range<unsigned>("--baud", number("--baud", opts.get("--baud")), 300, 4000000);
        if (opts.has("--timeout")) timeout_s = number("--timeout", opts.get("--timeout"));
        args = opts.positional;
        if (args.size() < 2) {
            usage(stderr);
            return 2;
        }
        const std::string port = args[0], cmd = args[1];
        std::vector<std::string> rest(args.begin() + 2, args.end());
        if (cmd == "set") {
            if (rest.empty()) bad_arg("set", "nothing to set");
            // Validate every argument before touching the module.
            proto_config_t probe{};
            for (const auto& a : rest) apply(probe, a);
        } else if (cmd != "identify" && cmd != "show") {
            bad_arg(cmd, "unknown command (identify, show, set)");
        }

        ModuleLink link(port, baud);
        proto_identity_t id = link.identify(timeout_s);
        print_identity(port, id);
        auger::io::require_protocol(id, port, "auger-module");
        if (cmd == "identify") return 0;
        proto_config_t cfg = link.read_config();
        if (cmd == "set") {
            for (const auto& a : rest) apply(cfg, a);
            cfg = link.write_config(cfg);
            // Read back through a fresh identity: the id is what the host keys modules on.
            proto_identity_t after = link.query_identity();
            print_identity(port, after);
        }
        print_config(cfg);
        return 0;
    } catch (const std::invalid_argument& e) {
        std::fprintf(stderr, "auger-module: %s\n", e.what());
        usage(stderr);
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "auger-module: %s\n", e.what());
        return 1;
    }
}
