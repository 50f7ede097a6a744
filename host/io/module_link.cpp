#include "module_link.hpp"

#include <cstring>
#include <stdexcept>


namespace auger::io {
namespace {

// docs/design.md: after the DTR reset the bootloader waits about 1 s; allow 2 s before asking.
constexpr double kBootWait_s = 2.0;

}  // namespace

ModuleLink::ModuleLink(const std::string& port, unsigned baud) : port_(port, baud)
{
    proto_parser_init(&parser_);
}

void ModuleLink::send_frame(const uint8_t* frame, size_t len, double timeout_s)
{
    port_.write_all(frame, len, timeout_s);
}

void ModuleLink::request(uint8_t what)
{
    uint8_t buf[PROTO_MAX_FRAME];
    proto_request_t rq{what};
    send_frame(buf, proto_encode_request(&rq, buf));
}

std::optional<proto_frame_t> ModuleLink::wait_frame(uint8_t type, double timeout_s)
{
    const double end = monotonic_s() + timeout_s;
    uint8_t buf[256];
    for (;;) {
        while (!frames_.empty()) {
            proto_frame_t f = frames_.front();
            frames_.pop_front();
            if (f.type == type) return f;
        }
        double left = end - monotonic_s();
        if (left <= 0) return std::nullopt;
        size_t n = port_.read_some(buf, sizeof buf, left);
        bytes_received_ += n;
        proto_frame_t f;
        for (size_t i = 0; i < n; ++i) {
            proto_parser_push(&parser_, buf[i]);
            while (proto_parser_pop(&parser_, &f)) frames_.push_back(f);
        }
    }
}

size_t ModuleLink::pump(std::vector<proto_frame_t>& out)
{
    const size_t before = out.size();
    while (!frames_.empty()) {
        out.push_back(frames_.front());
        frames_.pop_front();
    }
    uint8_t buf[512];
    // A full buffer may mean more is waiting; 250000 baud fills 512 bytes in 20 ms, so this
    // ends after a read or two.
    for (;;) {
        size_t n = port_.read_some(buf, sizeof buf, 0.0);
        bytes_received_ += n;
        proto_frame_t f;
        for (size_t i = 0; i < n; ++i) {
            proto_parser_push(&parser_, buf[i]);
            while (proto_parser_pop(&parser_, &f)) out.push_back(f);
        }
        if (n < sizeof buf) break;
    }
    return out.size() - before;
}

proto_identity_t ModuleLink::identify(double timeout_s)
{
    const double end = monotonic_s() + timeout_s;
    double wait_s = std::min(kBootWait_s, timeout_s);
    proto_identity_t id;
    for (;;) {
        auto f = wait_frame(PROTO_T_IDENTITY, wait_s);
        if (f && proto_decode_identity(&*f, &id)) return id;
        double left = end - monotonic_s();
        if (left <= 0)
            throw std::runtime_error(port() + ": no identity frame from the module within " +
                                     std::to_string(timeout_s) + " s (powered? right port and baud?)");
        request(PROTO_T_IDENTITY);
        wait_s = std::min(0.5, left);
    }
}

proto_identity_t ModuleLink::query_identity(double timeout_s)
{
    request(PROTO_T_IDENTITY);
    auto f = wait_frame(PROTO_T_IDENTITY, timeout_s);
    proto_identity_t id;
    if (!f || !proto_decode_identity(&*f, &id))
        throw std::runtime_error(port() + ": no identity frame in answer to a request");
    return id;
}

proto_config_t ModuleLink::read_config(double timeout_s)
{
    request(PROTO_T_CONFIG_REPORT);
    auto f = wait_frame(PROTO_T_CONFIG_REPORT, timeout_s);
    proto_config_t cfg;
    if (!f || !proto_decode_config_report(&*f, &cfg))
        throw std::runtime_error(port() + ": no configuration report from the module");
    return cfg;
}

proto_config_t ModuleLink::write_config(const proto_config_t& cfg, double timeout_s)
{
    uint8_t want[PROTO_MAX_FRAME], got[PROTO_MAX_FRAME];
    size_t n = proto_encode_config(&cfg, want);
    send_frame(want, n);
    auto f = wait_frame(PROTO_T_CONFIG_REPORT, timeout_s);
    proto_config_t stored;
    if (!f || !proto_decode_config_report(&*f, &stored))
        throw std::runtime_error(port() + ": the module did not answer the configuration frame");
    // Compare as the wire sees them (payload bytes), so float fields compare by their bits.
    proto_encode_config(&stored, got);
    if (std::memcmp(want, got, n) != 0)
        throw std::runtime_error(port() + ": the module refused the configuration (is its motor "
                                          "enabled, or is a value outside its limits?)");
    return stored;
}

}  // namespace auger::io
