// Writes the same synthetic robot samples to CSV and MCAP, for python/tests/test_end_to_end.py
// to compare the two value by value:
//   mcap_samples OUT.csv OUT.mcap   RobotLogWriter and RobotLogMcapWriter side by side
//   mcap_samples --augerd DIR       augerd's own log writer ([log] mcap = true) with rotation
//                                   every ~20 kB: DIR/augerd-*-N.csv, each with its .mcap
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <thread>

#include "auger/log.hpp"
#include "auger/log_mcap.hpp"
#include "data_log.hpp"

namespace {

const std::vector<std::pair<std::string, std::string>> kMeta = {
    {"format", auger::kRobotLogFormat}, {"terrain", "sand"}, {"t0_unix_s", "1767225600.000250"}, {"writer", "test"}};

// 500 rows: sparse poses, a lost module now and then, a reference from row 101 on.
void samples(const std::function<void(int k, const auger::RobotSample&)>& out) {
  for (int k = 0; k < 500; ++k) {
    auger::RobotSample s{};
    s.t_s = 0.01 * k;
    for (int i = 0; i < 4; ++i) {
      s.omega_rpm[std::size_t(i)] = 10 * std::sin(0.01 * k + i);
      s.cmd_rpm[std::size_t(i)] = std::round(s.omega_rpm[std::size_t(i)]);
      s.current_a[std::size_t(i)] = 0.4 + 0.001 * k;
      s.voltage_v[std::size_t(i)] = 18.5;
      s.pwm[std::size_t(i)] = 0.3;
      if (k % 50 != 7) s.status[std::size_t(i)] = (k / 100) * 256 + 3;
      s.seq_ack[std::size_t(i)] = k;
    }
    if (k % 3 == 0) s.x_m = 0.001 * k, s.y_m = -0.002 * k, s.psi_rad = 3.1 - 0.02 * k;
    s.imu_psi_rad = 0.5, s.imu_r_radps = 0.01;
    if (k > 100) s.xd_m = 0.2, s.yd_m = 0.1, s.psid_rad = 0;
    s.loop_dt_s = 0.01 + 1e-5 * (k % 7);
    out(k, s);
  }
}

int side_by_side(const char* csv_path, const char* mcap_path) {
  const std::vector<std::string> extra = {"mode", "pose_capture_t_s"};
  std::ofstream csv(csv_path), mcap(mcap_path, std::ios::binary);
  auger::RobotLogWriter w(csv, kMeta, extra);
  // small chunks: the file gets several, as augerd's 1 s flushes would make
  auger::RobotLogMcapWriter m(mcap, kMeta, auger::RobotLogMcapWriter::RobotColumnsAnd{extra}, 4096);
  samples([&](int k, const auger::RobotSample& s) {
    const std::vector<double> ex = {double(k % 4), k % 3 == 0 ? s.t_s - 0.05 : NAN};
    w.write(s, ex);
    m.write(s, ex);
    if (k % 100 == 99) m.flush();
  });
  m.finish();
  w.flush();
  return csv && mcap ? 0 : 1;
}

int augerd_log(const char* dir) {
  augerd::DataLogConfig c;
  c.dir = dir;
  c.run = "augerd-test";
  c.metadata = kMeta;
  c.flush_interval_s = 0.01;
  c.rotate_bytes = 20000;
  c.mcap = true;
  augerd::DataLog log(c);
  log.open();
  std::vector<double> extra(augerd::replay_columns().size());
  samples([&](int k, const auger::RobotSample& s) {
    for (std::size_t j = 0; j < extra.size(); ++j) extra[j] = (k + int(j)) % 5 == 0 ? NAN : 0.5 * double(k) - double(j);
    log.write(s, extra);
    if (k % 20 == 19) std::this_thread::sleep_for(std::chrono::milliseconds(15));  // several flushes a file
  });
  log.close();
  const auto st = log.stats();
  std::printf("%llu rows in %llu files, %llu lost\n", static_cast<unsigned long long>(st.rows_written),
              static_cast<unsigned long long>(st.files), static_cast<unsigned long long>(st.rows_lost));
  return st.rows_written == 500 && st.rows_lost == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--augerd") == 0) return augerd_log(argv[2]);
  if (argc == 3) return side_by_side(argv[1], argv[2]);
  std::fprintf(stderr, "usage: mcap_samples OUT.csv OUT.mcap | mcap_samples --augerd DIR\n");
  return 2;
}
