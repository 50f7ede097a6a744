#include "fil_rig.hpp"

#include "step_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace auger::fil {

std::string firmware_elf() { return AUGER_FIRMWARE_ELF; }

Rig::Rig(const RigOptions& opt) : count_(opt.count), mods_(size_t(opt.count))
{
    simmod_config_t cfg;
    simmod_config_default(&cfg);
    const std::string elf = opt.elf_path.empty() ? firmware_elf() : opt.elf_path;
    cfg.elf_path = elf.c_str();
    cfg.count = opt.count;
    cfg.threads = opt.threads;
    cfg.ina219_addr7 = opt.ina219_addr7;
    sim_ = simmod_create(&cfg);
    if (!sim_) throw std::runtime_error("simmod_create failed for " + elf);
    for (auto& m : mods_) proto_parser_init(&m.parser);
    simmod_set_uart_callback(sim_, &Rig::on_byte, this);
    if (opt.battery_v > 0)
        for (int i = 0; i < count_; ++i) simmod_set_battery_voltage(sim_, i, opt.battery_v);
}

Rig::~Rig() { simmod_destroy(sim_); }

double Rig::t_s() const { return simmod_time_s(sim_); }

void Rig::on_byte(void* ctx, int module, uint8_t byte, double t_s)
{
    auto* rig = static_cast<Rig*>(ctx);
    Module& m = rig->mods_.at(size_t(module));
    proto_parser_push(&m.parser, byte);
    proto_frame_t f;
    while (proto_parser_pop(&m.parser, &f)) {
        Telemetry t{t_s, {}};
        proto_identity_t id;
        proto_config_t cfg;
        proto_fault_t ft;
        if (proto_decode_telemetry(&f, &t.tm)) m.telemetry.push_back(t);
        else if (proto_decode_identity(&f, &id)) m.identities.push_back(id);
        else if (proto_decode_config_report(&f, &cfg)) m.configs.push_back(cfg);
        else if (proto_decode_fault(&f, &ft)) m.faults.push_back(ft);
    }
}

void Rig::command(int m, double omega_rpm, uint8_t flags)
{
    Module& mod = mods_.at(size_t(m));
    mod.sending = true;
    mod.omega_rpm = omega_rpm;
    mod.flags = flags;
}

void Rig::stop_sending(int m) { mods_.at(size_t(m)).sending = false; }

void Rig::send_raw(int m, const std::vector<uint8_t>& bytes)
{
    simmod_uart_send(sim_, m, bytes.data(), bytes.size());
}

void Rig::send_request(int m, uint8_t what)
{
    uint8_t buf[PROTO_MAX_FRAME];
    proto_request_t rq{what};
    size_t n = proto_encode_request(&rq, buf);
    simmod_uart_send(sim_, m, buf, n);
}

void Rig::send_config(int m, const proto_config_t& cfg)
{
    uint8_t buf[PROTO_MAX_FRAME];
    size_t n = proto_encode_config(&cfg, buf);
    simmod_uart_send(sim_, m, buf, n);
}

proto_config_t Rig::read_config(int m)
{
    size_t before = config_reports(m).size();
    send_request(m, PROTO_T_CONFIG_REPORT);
    run_for(0.05);
    if (config_reports(m).size() != before + 1)
        throw std::runtime_error("module " + std::to_string(m) + " sent no config report");
    return config_reports(m).back();
}

void Rig::write_config(int m, const proto_config_t& cfg)
{
    size_t before = config_reports(m).size();
    send_config(m, cfg);
    run_for(0.3);  // EEPROM: 3.3 ms a byte, 35 bytes
    if (config_reports(m).size() != before + 1)
        throw std::runtime_error("module " + std::to_string(m) + " did not answer a CONFIG frame");
    uint8_t a[PROTO_MAX_FRAME], b[PROTO_MAX_FRAME];
    proto_encode_config_report(&cfg, a);
    proto_encode_config_report(&config_reports(m).back(), b);
    if (std::memcmp(a, b, PROTO_FRAME_SIZE(PROTO_LEN_CONFIG)) != 0)
        throw std::runtime_error("module " + std::to_string(m) + " refused the configuration");
}

void Rig::send_setpoints()
{
    for (int i = 0; i < count_; ++i) {
        Module& m = mods_[size_t(i)];
        if (!m.sending) continue;
        proto_setpoint_t sp{};
        sp.seq = ++m.seq;
        sp.omega_crpm = int16_t(std::lround(m.omega_rpm * 100.0));
        sp.flags = m.flags;
        uint8_t buf[PROTO_MAX_FRAME];
        size_t n = proto_encode_setpoint(&sp, buf);
        simmod_uart_send(sim_, i, buf, n);
    }
}

void Rig::run_for(double dt_s)
{
    const double period_s = 0.01;
    const double end_s = t_s() + dt_s;
    while (t_s() < end_s - 1e-9) {
        send_setpoints();
        simmod_step_to(sim_, std::min(end_s, t_s() + period_s));
    }
}

const Telemetry& Rig::last(int m) const
{
    const auto& t = mods_.at(size_t(m)).telemetry;
    if (t.empty()) throw std::runtime_error("no telemetry from module " + std::to_string(m));
    return t.back();
}

StepMetrics step_metrics(const std::vector<Telemetry>& tel, double t_step_s, double omega0_rpm,
                         double omega1_rpm)
{
    // One definition of the figures for this test and `auger step` (host/operator).
    std::vector<auger::op::StepSample> samples;
    samples.reserve(tel.size());
    for (const auto& s : tel) samples.push_back({s.t_s, s.omega_rpm()});
    const auger::op::StepSummary sum = auger::op::summarize_step(samples, t_step_s, omega0_rpm, omega1_rpm);
    return StepMetrics{sum.rise_time_s, sum.overshoot_pct, sum.steady_error_rpm};
}

}  // namespace auger::fil
