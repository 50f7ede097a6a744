#include "sim_rig.hpp"

#include <cstdio>
#include <stdexcept>
#include <vector>

#include <fcntl.h>
#include <time.h>
#include <unistd.h>

#include "pty_bridge.h"
#include "simmod.h"

struct SimRig::Bridge {
  pty_bridge_t b{};
  bool open = false;
};

double SimRig::wall_s() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

namespace {

// augerd is spawned from this process: if it inherited the masters, closing one here would
// not hang up its port.
void no_inherit(int fd) { fcntl(fd, F_SETFD, fcntl(fd, F_GETFD) | FD_CLOEXEC); }

// Configuration exchange with the simulated modules before any host opens a port (batch time).
struct Setup {
  std::array<proto_parser_t, 4> parsers{};
  std::array<bool, 4> got{};
  std::array<proto_config_t, 4> report{};
};

void setup_byte(void* ctx, int module, uint8_t byte, double) {
  auto* s = static_cast<Setup*>(ctx);
  proto_parser_push(&s->parsers[std::size_t(module)], byte);
  proto_frame_t f;
  while (proto_parser_pop(&s->parsers[std::size_t(module)], &f))
    if (proto_decode_config_report(&f, &s->report[std::size_t(module)])) s->got[std::size_t(module)] = true;
}

void wait_reports(simmod_t* sim, Setup& s, const char* what) {
  for (double t = simmod_time_s(sim); t < 30; t += 0.01) {
    simmod_step_to(sim, t);
    if (s.got[0] && s.got[1] && s.got[2] && s.got[3]) return;
  }
  throw std::runtime_error(std::string("sim rig: no configuration report ") + what);
}

}  // namespace

SimRig::SimRig(const std::string& dir, std::array<int, 4> ids, std::array<int, 4> perm,
               std::array<int, 4> telemetry_ms)
    : dir_(dir), perm_(perm) {
  simmod_config_t cfg;
  simmod_config_default(&cfg);
  cfg.elf_path = AUGER_FIRMWARE_ELF;
  cfg.count = 4;
  cfg.realtime = 0;  // paced here, in 1 ms slices against CLOCK_MONOTONIC
  cfg.threads = 1;
  sim_ = simmod_create(&cfg);
  if (!sim_) throw std::runtime_error("sim rig: simmod_create failed");
  // Give each module its id through the protocol, as auger-module does on the bench.
  Setup s;
  for (auto& p : s.parsers) proto_parser_init(&p);
  simmod_set_uart_callback(sim_, setup_byte, &s);
  simmod_step_to(sim_, 0.2);
  uint8_t buf[PROTO_MAX_FRAME];
  for (int m = 0; m < 4; ++m) {
    proto_request_t rq{PROTO_T_CONFIG_REPORT};
    simmod_uart_send(sim_, m, buf, proto_encode_request(&rq, buf));
  }
  wait_reports(sim_, s, "to a request");
  for (int m = 0; m < 4; ++m) {
    proto_config_t c = s.report[std::size_t(m)];
    c.module_id = uint8_t(ids[std::size_t(m)]);
    c.telemetry_period_ms = uint8_t(telemetry_ms[std::size_t(m)]);
    s.got[std::size_t(m)] = false;
    simmod_uart_send(sim_, m, buf, proto_encode_config(&c, buf));
  }
  wait_reports(sim_, s, "after writing the id");
  for (int m = 0; m < 4; ++m)
    if (s.report[std::size_t(m)].module_id != ids[std::size_t(m)] ||
        s.report[std::size_t(m)].telemetry_period_ms != telemetry_ms[std::size_t(m)])
      throw std::runtime_error("sim rig: id or telemetry period refused");
  simmod_set_uart_callback(sim_, nullptr, nullptr);

  for (auto& p : from_module_) proto_parser_init(&p);
  for (auto& p : to_module_) proto_parser_init(&p);
  for (std::size_t k = 0; k < 4; ++k) {
    bridges_[k] = new Bridge;
    if (pty_bridge_open(&bridges_[k]->b, port(int(k)).c_str()) != 0) throw std::runtime_error("sim rig: no pty");
    no_inherit(bridges_[k]->b.master_fd);
    bridges_[k]->open = true;
  }
  simmod_set_uart_callback(sim_, on_byte, this);
  for (auto& b : battery_req_) b = -1.0;
  thread_ = std::thread([this] { loop(); });
}

SimRig::~SimRig() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  for (auto* b : bridges_) {
    if (b && b->open) pty_bridge_close(&b->b);
    delete b;
  }
  simmod_destroy(sim_);
}

void SimRig::in_sim(std::function<void(simmod_t*)> f) {
  std::lock_guard<std::mutex> lock(mutex_);
  actions_.push_back(std::move(f));
}

SimRig::ModuleView SimRig::module(int m) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return views_[std::size_t(m)];
}

void SimRig::on_byte(void* ctx, int module, uint8_t byte, double) {
  auto* rig = static_cast<SimRig*>(ctx);
  proto_parser_t& p = rig->from_module_[std::size_t(module)];
  proto_parser_push(&p, byte);
  proto_frame_t f;
  proto_telemetry_t tm;
  while (proto_parser_pop(&p, &f))
    if (proto_decode_telemetry(&f, &tm)) {
      std::lock_guard<std::mutex> lock(rig->mutex_);
      auto& v = rig->views_[std::size_t(module)];
      v.tm = tm;
      v.tm_wall_s = wall_s();
      ++v.tm_count;
    }
  for (std::size_t k = 0; k < 4; ++k) {
    if (rig->perm_[k] != module) continue;
    Bridge* b = rig->bridges_[k];
    if (!b->open || rig->mute_[k]) continue;
    // Corruption flips one bit of every byte: every frame fails its CRC or header.
    const uint8_t out = rig->corrupt_[k] ? uint8_t(byte ^ 0x10) : byte;
    pty_bridge_write(&b->b, &out, 1);
  }
}

void SimRig::loop() {
  t0_wall_s_ = wall_s() - simmod_time_s(sim_);
  uint8_t buf[256];
  while (!stop_) {
    for (std::size_t k = 0; k < 4; ++k) {
      Bridge* b = bridges_[k];
      const int m = perm_[k];
      if (close_req_[k].exchange(false) && b->open) {
        pty_bridge_close(&b->b);
        b->open = false;
      }
      if (reopen_req_[k].exchange(false) && !b->open) {
        b->b = pty_bridge_t{};
        if (pty_bridge_open(&b->b, port(int(k)).c_str()) == 0) {
          no_inherit(b->b.master_fd);
          b->open = true;
        }
      }
      if (!b->open) continue;
      // A host opening the port resets the module, as DTR does on the real board.
      if (pty_bridge_poll_open(&b->b)) simmod_reset(sim_, m);
      size_t n;
      while ((n = pty_bridge_read(&b->b, buf, sizeof buf)) > 0) {
        simmod_uart_send(sim_, m, buf, n);
        proto_parser_t& p = to_module_[std::size_t(m)];
        proto_frame_t f;
        for (size_t i = 0; i < n; ++i) {
          proto_parser_push(&p, buf[i]);
          while (proto_parser_pop(&p, &f))
            if (f.type == PROTO_T_SETPOINT) {
              std::lock_guard<std::mutex> lock(mutex_);
              // In the module's time (mapped to wall time), when it receives the frame: under
              // load the paced simulation may trail the wall clock by a few ms.
              views_[std::size_t(m)].last_setpoint_wall_s = t0_wall_s_ + simmod_time_s(sim_);
              ++views_[std::size_t(m)].setpoints;
            }
        }
      }
    }
    for (int m = 0; m < 4; ++m) {
      const double v = battery_req_[std::size_t(m)].exchange(-1.0);
      if (v >= 0) simmod_set_battery_voltage(sim_, m, v);
    }
    {
      std::vector<std::function<void(simmod_t*)>> todo;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        todo.swap(actions_);
      }
      for (auto& f : todo) f(sim_);
    }
    simmod_step_to(sim_, wall_s() - t0_wall_s_);
    {
      // The motor's own pin, not its telemetry (which trails by up to one 10 ms period): the
      // kill -9 test times the stop from here.
      const double now_wall_s = t0_wall_s_ + simmod_time_s(sim_);
      std::lock_guard<std::mutex> lock(mutex_);
      for (int m = 0; m < 4; ++m) {
        const double quiet_s = simmod_pwm_quiet_s(sim_, m);
        const bool off = simmod_pwm_duty(sim_, m) == 0.0 && quiet_s > 0.004;
        double& off_wall_s = views_[std::size_t(m)].pwm_off_wall_s;
        if (!off) off_wall_s = 0;
        else if (off_wall_s == 0) off_wall_s = now_wall_s - quiet_s;
      }
    }
    usleep(500);
  }
}
