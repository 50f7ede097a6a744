// Writes the same synthetic robot samples with RobotLogWriter (CSV) and RobotLogMcapWriter's
// sample interface (the one augerd would use): python/tests/test_end_to_end.py compares the
// two files value by value. Usage: mcap_samples OUT.csv OUT.mcap
#include <cmath>
#include <cstdio>
#include <fstream>

#include "auger/log.hpp"
#include "auger/log_mcap.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: mcap_samples OUT.csv OUT.mcap\n");
    return 2;
  }
  const std::vector<std::pair<std::string, std::string>> meta = {
      {"format", auger::kRobotLogFormat}, {"terrain", "sand"}, {"t0_unix_s", "1767225600.000250"}, {"writer", "test"}};
  const std::vector<std::string> extra = {"mode", "pose_capture_t_s"};
  std::ofstream csv(argv[1]), mcap(argv[2], std::ios::binary);
  auger::RobotLogWriter w(csv, meta, extra);
  // small chunks: the file gets several, as augerd's 1 s flushes would make
  auger::RobotLogMcapWriter m(mcap, meta, auger::RobotLogMcapWriter::RobotColumnsAnd{extra}, 4096);
  auger::RobotSample s;
  for (int k = 0; k < 500; ++k) {
    s = auger::RobotSample{};
    s.t_s = 0.01 * k;
    for (int i = 0; i < 4; ++i) {
      s.omega_rpm[std::size_t(i)] = 10 * std::sin(0.01 * k + i);
      s.cmd_rpm[std::size_t(i)] = std::round(s.omega_rpm[std::size_t(i)]);
      s.current_a[std::size_t(i)] = 0.4 + 0.001 * k;
      s.voltage_v[std::size_t(i)] = 18.5;
      s.pwm[std::size_t(i)] = 0.3;
      if (k % 50 != 7) s.status[std::size_t(i)] = (k / 100) * 256 + 3;  // a lost module now and then
      s.seq_ack[std::size_t(i)] = k;
    }
    if (k % 3 == 0) s.x_m = 0.001 * k, s.y_m = -0.002 * k, s.psi_rad = 3.1 - 0.02 * k;
    s.imu_psi_rad = 0.5, s.imu_r_radps = 0.01;
    if (k > 100) s.xd_m = 0.2, s.yd_m = 0.1, s.psid_rad = 0;
    s.loop_dt_s = 0.01 + 1e-5 * (k % 7);
    const std::vector<double> ex = {double(k % 4), k % 3 == 0 ? s.t_s - 0.05 : NAN};
    w.write(s, ex);
    m.write(s, ex);
    if (k % 100 == 99) m.flush();
  }
  m.finish();
  w.flush();
  return csv && mcap ? 0 : 1;
}
