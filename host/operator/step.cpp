// auger step MODULE RPM: a velocity step on one module, directly on its serial port (augerd not
// running) or through augerd's `spin` command; every telemetry frame recorded (the module sends
// one per 10 ms), summarised against the firmware's step-test criteria, optionally written to
// CSV and plotted with gnuplot. docs/operator.md.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "auger/args.hpp"
#include "auger/log.hpp"
#include "augerd_client.hpp"
#include "common.hpp"
#include "gnuplot.hpp"
#include "module_adapter.hpp"
#include "module_link.hpp"
#include "operator.hpp"
#include "status.hpp"
#include "step_metrics.hpp"

namespace auger::op {
namespace {

constexpr double kBefore_s = 0.5;  // at the starting speed before the step

const CommandLine& step_cli() {
  static const CommandLine cli{
      "auger step",
      "MODULE RPM [OPTIONS]",
      "A velocity step of module MODULE (0..3) from --from to RPM, held --duration: directly on the\n"
      "module's serial port (--port; augerd must not run), else through augerd's commands socket (the\n"
      "robot enabled and not tracking). Prints rise time (10-90 %), overshoot, steady-state error\n"
      "(mean over the last 0.5 s) and settling time (5 % band) against the firmware's criteria.\n",
      {{"--from", "RPM", "the speed before the step (default 0 rpm)"},
       {"--duration", "S", "how long the new speed is held (default 1.5 s; 0.6 .. 60 s)"},
       {"--port", "DEV", "directly on the module's serial port (augerd must not run)"},
       {"--baud", "N", "with --port (default 250000)"},
       socket_option(),
       {"--enable", "", "through augerd: send enable first and stop after"},
       {"--out", "CSV", "write the samples: t_s, omega_rpm, omega_cmd_rpm"},
       {"--plot", "SVG|-", "plot speed and setpoint with gnuplot; - draws in the terminal"}},
      "Exit 0: every criterion met; 1: one fails; 2: bad usage; 3: no module or augerd.\n"};
  return cli;
}

void step_usage(std::FILE* f) { step_cli().print_usage(f); }

struct Recorder {
  std::vector<StepSample> samples;
  std::vector<double> cmd_rpm;
  uint32_t last_ms = 0;
  bool have = false;
  double t0_ms = 0;
  // Keyed on the module's clock, as augerd does: each telemetry frame once.
  void add(uint32_t time_ms, double omega_rpm, double cmd) {
    if (have && int32_t(time_ms - last_ms) <= 0) return;
    if (!have) t0_ms = time_ms;
    have = true;
    last_ms = time_ms;
    samples.push_back({(double(time_ms) - t0_ms) / 1000.0, omega_rpm});
    cmd_rpm.push_back(cmd);
  }
};

// Directly on the port: setpoints at 100 Hz with ENABLE (and CLEAR_FAULTS on the first).
void run_direct(const std::string& port, unsigned baud, int module, double from_rpm, double to_rpm, double hold_s,
                Recorder& rec, double& t_step_s) {
  io::ModuleLink link(port, baud);
  const proto_identity_t id = link.identify(4.0);
  if (id.module_id != module)
    throw std::runtime_error(port + " has module " + std::to_string(id.module_id) + ", not " + std::to_string(module));
  const double t0 = now_s();
  uint16_t seq = 0;
  std::vector<proto_frame_t> frames;
  bool stepped = false;
  for (double next = t0; now_s() - t0 < kBefore_s + hold_s; next += 0.01) {
    const double t = now_s() - t0;
    const double rpm = t < kBefore_s ? from_rpm : to_rpm;
    uint8_t buf[PROTO_MAX_FRAME];
    link.send_frame(buf, io::encode_setpoint(seq, rpm, true, seq == 0, buf));
    ++seq;
    frames.clear();
    link.pump(frames);
    for (const auto& f : frames) {
      proto_telemetry_t frame;
      if (!proto_decode_telemetry(&f, &frame)) continue;
      io::ModuleTelemetry tm;
      tm.take(frame);
      rec.add(frame.time_ms, tm.omega_rpm(), tm.omega_cmd_rpm());
      if (frame.status & PROTO_F_MASK) throw std::runtime_error(port + ": module reports " + fault_bits_text(frame.status));
      if (!stepped && rpm == to_rpm && !rec.samples.empty()) {
        // The step is the first frame whose setpoint in use is the new one.
        if (std::fabs(tm.omega_cmd_rpm() - to_rpm) < 0.01) {
          t_step_s = rec.samples.back().t_s;
          stepped = true;
        }
      }
    }
    sleep_s(next + 0.01 - now_s());
  }
  // Motor off: a setpoint 0 without ENABLE.
  uint8_t buf[PROTO_MAX_FRAME];
  link.send_frame(buf, io::encode_setpoint(seq++, 0.0, false, false, buf));
  if (!stepped) throw std::runtime_error(port + ": the module never applied the new setpoint");
}

// Through augerd: `spin MODULE RPM` refreshed every cycle (it expires like vel), `status all`
// polled every cycle; answers come once per augerd cycle, so the loop runs at its rate.
void run_augerd(const std::string& socket, bool enable, int module, double from_rpm, double to_rpm, double hold_s,
                Recorder& rec, double& t_step_s) {
  io::AugerdClient c(socket);
  if (enable) {
    const std::string a = c.request("enable");
    if (a != "ok") throw std::runtime_error("augerd refused enable: " + a);
  }
  const double t0 = now_s();
  bool stepped = false;
  // Two requests in flight: augerd serves the socket once per cycle, so one pair is always
  // waiting for the next cycle and every cycle yields a sample.
  auto send_pair = [&] {
    char line[64];
    std::snprintf(line, sizeof line, "spin %d %.3f", module, now_s() - t0 < kBefore_s ? from_rpm : to_rpm);
    if (!c.send_line(line) || !c.send_line("status all")) throw std::runtime_error("augerd went away");
  };
  send_pair();
  send_pair();
  while (now_s() - t0 < kBefore_s + hold_s) {
    std::string a, st;
    if (!c.read_line(a) || !c.read_line(st)) throw std::runtime_error("augerd did not answer");
    if (a != "ok") throw std::runtime_error("augerd: " + a);
    send_pair();
    daemon::Status status;
    if (const std::string bad = daemon::parse_status(st, status); !bad.empty())
      throw std::runtime_error("augerd's status all: " + bad);
    if (status.fault != "none") throw std::runtime_error("augerd reports fault=" + status.fault);
    if (!status.all) throw std::runtime_error("augerd's status all has no module fields (an older augerd?)");
    const daemon::ModuleStatus& ms = status.modules[std::size_t(module)];
    const double cmd = ms.omega_cmd_rpm;
    rec.add(ms.time_ms, ms.omega_rpm, cmd);
    if (!stepped && std::fabs(cmd - to_rpm) < 0.01 && !rec.samples.empty()) {
      t_step_s = rec.samples.back().t_s;
      stepped = true;
    }
  }
  for (int i = 0; i < 4; ++i) {  // the two pairs still in flight
    std::string a;
    c.read_line(a);
  }
  c.request("spin " + std::to_string(module) + " 0");
  if (enable) c.request("stop");
  if (!stepped) throw std::runtime_error("the module never applied the new setpoint");
}

}  // namespace

void write_step_csv(const std::string& path, const std::vector<double>& t_s, const std::vector<double>& omega_rpm,
                    const std::vector<double>& omega_cmd_rpm) {
  std::ofstream f(path);
  CsvLogWriter w(f, {}, {"t_s", "omega_rpm", "omega_cmd_rpm"});
  for (std::size_t i = 0; i < t_s.size(); ++i) {
    const double row[] = {t_s[i], omega_rpm[i], omega_cmd_rpm[i]};
    w.write_row(row, 3);
  }
  f.flush();
  if (!f) throw std::runtime_error("cannot write " + path);
}

std::string plot_step(io::Gnuplot& gp, const std::string& csv_path, const std::string& plot) {
  // Every path is a gnuplot literal (gp_quote) and gnuplot runs without a shell: a path with
  // quotes or ';' in it names a file, it is never executed.
  const std::string term = plot == "-" ? "set terminal dumb size 100,30\n"
                                       : "set terminal svg size 800,480\nset output " + io::gp_quote(plot) + "\n";
  return gp.run_script("step", term +
                                   "set datafile separator ','\nset key autotitle columnhead\n"
                                   "set xlabel 't (s)'\nset ylabel 'omega (rpm)'\n"
                                   "plot " + io::gp_quote(csv_path) + " using 1:2 with lines, '' using 1:3 with steps\n"
                                   "set output");
}

int run_step(int argc, char** argv) {
  try {
    std::vector<std::string> pos;
    std::string port, socket = io::kDefaultCommandsSocket, out, plot;
    unsigned baud = io::ModuleLink::kDefaultBaud;
    double from_rpm = 0, hold_s = 1.5;
    bool enable = false;
    Args a;
    if (const int rc = step_cli().parse_or_answer(argc, argv, a); rc >= 0) return rc;
    double baud_d = baud;
    if (!a.number("auger step", "--baud", baud_d, baud_d) || !a.number("auger step", "--from", from_rpm, from_rpm) ||
        !a.number("auger step", "--duration", hold_s, hold_s))
      return step_usage(stderr), 2;
    baud = unsigned(baud_d);
    port = a.get("--port");
    socket = a.get("--socket", socket);
    out = a.get("--out");
    plot = a.get("--plot");
    enable = a.has("--enable");
    pos = a.positional;
    if (pos.size() != 2) throw UsageError("expected MODULE and RPM");
    const double module_d = parse_number("MODULE", pos[0]);
    if (module_d != 0 && module_d != 1 && module_d != 2 && module_d != 3) throw UsageError("MODULE must be 0..3");
    const int module = int(module_d);
    const double to_rpm = parse_number("RPM", pos[1]);
    if (to_rpm == from_rpm) throw UsageError("RPM equals the starting speed (--from): no step");
    if (!(hold_s >= 0.6 && hold_s <= 60)) throw UsageError("--duration must be within 0.6 .. 60 s");
    Recorder rec;
    double t_step_s = NAN;
    try {
      if (!port.empty()) run_direct(port, baud, module, from_rpm, to_rpm, hold_s, rec, t_step_s);
      else run_augerd(socket, enable, module, from_rpm, to_rpm, hold_s, rec, t_step_s);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "auger step: %s\n", e.what());
      return 3;
    }
    const StepSummary s = summarize_step(rec.samples, t_step_s, from_rpm, to_rpm);
    const bool rise_ok = s.rise_time_s <= kRiseMax_s, over_ok = s.overshoot_pct <= kOvershootMax_pct,
               err_ok = s.steady_error_rpm <= kSteadyErrorMax_rpm;
    std::printf("step module %d: %.2f -> %.2f rpm, %d samples after the step (%.0f Hz)\n", module, from_rpm, to_rpm,
                s.samples, s.samples > 1 ? (s.samples - 1) / (rec.samples.back().t_s - t_step_s) : 0.0);
    std::printf("  rise time (10-90 %%)  %.3f s    (<= %.1f s: %s)\n", s.rise_time_s, kRiseMax_s, rise_ok ? "ok" : "FAIL");
    std::printf("  overshoot           %.1f %%     (<= %.0f %%: %s)\n", s.overshoot_pct, kOvershootMax_pct,
                over_ok ? "ok" : "FAIL");
    std::printf("  steady-state error  %.3f rpm  (<= %.1f rpm: %s)\n", s.steady_error_rpm, kSteadyErrorMax_rpm,
                err_ok ? "ok" : "FAIL");
    std::printf("  settling time (5 %%) %.3f s\n", s.settling_time_s);
    std::vector<double> t_s, omega_rpm;
    for (const auto& x : rec.samples) t_s.push_back(x.t_s), omega_rpm.push_back(x.omega_rpm);
    if (!out.empty()) write_step_csv(out, t_s, omega_rpm, rec.cmd_rpm);
    if (!plot.empty()) {
      try {
        io::Gnuplot gp;  // the CSV goes to its private directory unless --out named one
        const std::string csv = out.empty() ? gp.path("step.csv") : out;
        if (out.empty()) write_step_csv(csv, t_s, omega_rpm, rec.cmd_rpm);
        std::fflush(stdout);
        std::fputs(plot_step(gp, csv, plot).c_str(), stdout);
        if (plot != "-") std::printf("  plot: %s\n", plot.c_str());
      } catch (const io::PlotError& e) {
        std::fprintf(stderr, "auger step: %s\n", e.what());
      }
    }
    if (!out.empty()) std::printf("  samples: %s\n", out.c_str());
    return rise_ok && over_ok && err_ok ? 0 : 1;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "auger step: %s\n", e.what());
    step_usage(stderr);
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger step: %s\n", e.what());
    return 3;
  }
}

}  // namespace auger::op
