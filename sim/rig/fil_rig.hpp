// Firmware-in-the-loop rig: the real firmware image in N simulated modules (sim/simmod.h),
// and a host that behaves like augerd: every 10 ms of simulated time it sends each module the
// setpoint it holds, and it parses everything the modules send with shared/protocol.h.
#pragma once

#include "protocol.h"
#include "simmod.h"

#include <cstdint>
#include <string>
#include <vector>

namespace auger::fil {

struct Telemetry {
    double t_s;  // simulated time the frame's last byte left the module
    proto_telemetry_t tm;
    double omega_rpm() const { return tm.omega_crpm / 100.0; }
};

struct RigOptions {
    RigOptions(int count_ = 1, double battery_v_ = 0.0, int threads_ = 1)
        : count(count_), battery_v(battery_v_), threads(threads_) {}
    int count;
    double battery_v;      // > 0: force every module's battery terminal voltage
    int threads;
    std::string elf_path;  // empty: the firmware under test (firmware_elf())
    uint8_t ina219_addr7 = 0x40;  // another address: the firmware's INA219 never answers
};

class Rig {
public:
    explicit Rig(const RigOptions& opt = {});
    ~Rig();
    Rig(const Rig&) = delete;
    Rig& operator=(const Rig&) = delete;

    simmod_t* sim() { return sim_; }
    int count() const { return count_; }
    double t_s() const;

    // The setpoint the host sends module m every 10 ms from now on (seq increments).
    void command(int m, double omega_rpm, uint8_t flags);
    // Stop sending setpoints to module m (as if augerd died).
    void stop_sending(int m);
    // Advance by dt_s in 10 ms host periods; the host sends at the start of each period.
    void run_for(double dt_s);
    // Raw bytes to module m now (e.g. a damaged frame).
    void send_raw(int m, const std::vector<uint8_t>& bytes);
    void send_request(int m, uint8_t what);
    void send_config(int m, const proto_config_t& cfg);
    // Reads module m's settings, changes them with `edit`, writes them (CONFIG frame) and
    // waits for the report; throws if the module does not report what was written.
    template <typename Edit>
    proto_config_t reconfigure(int m, Edit edit)
    {
        proto_config_t cfg = read_config(m);
        edit(cfg);
        write_config(m, cfg);
        return cfg;
    }
    proto_config_t read_config(int m);
    void write_config(int m, const proto_config_t& cfg);

    const std::vector<Telemetry>& telemetry(int m) const { return mods_[m].telemetry; }
    const std::vector<proto_identity_t>& identities(int m) const { return mods_[m].identities; }
    const std::vector<proto_config_t>& config_reports(int m) const { return mods_[m].configs; }
    const std::vector<proto_fault_t>& fault_frames(int m) const { return mods_[m].faults; }
    const Telemetry& last(int m) const;
    uint16_t last_seq_sent(int m) const { return mods_[m].seq; }
    // Frames the host's parser dropped from module m (should stay 0 on a clean link).
    uint16_t host_dropped(int m) const { return proto_parser_dropped(&mods_[m].parser); }

private:
    struct Module {
        proto_parser_t parser;
        bool sending = false;
        double omega_rpm = 0;
        uint8_t flags = 0;
        uint16_t seq = 0;
        std::vector<Telemetry> telemetry;
        std::vector<proto_identity_t> identities;
        std::vector<proto_config_t> configs;
        std::vector<proto_fault_t> faults;
    };
    static void on_byte(void* ctx, int module, uint8_t byte, double t_s);
    void send_setpoints();

    simmod_t* sim_ = nullptr;
    int count_ = 0;
    std::vector<Module> mods_;
};

// Path of the firmware image under test (compile definition AUGER_FIRMWARE_ELF).
std::string firmware_elf();

struct StepMetrics {
    double rise_time_s;     // 10 % to 90 % of the step
    double overshoot_pct;   // beyond the final value, % of the step
    double steady_error_rpm;  // |mean error| over the last 0.5 s
};

// Step from omega0 to omega1 commanded at t_step_s, measured on module m's telemetry up to now.
StepMetrics step_metrics(const std::vector<Telemetry>& tel, double t_step_s, double omega0_rpm,
                         double omega1_rpm);

}  // namespace auger::fil
