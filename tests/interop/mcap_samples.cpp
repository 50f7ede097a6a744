// Writes the same synthetic robot samples to CSV and MCAP, for python/tests/test_end_to_end.py
// to compare the two value by value:
//   mcap_samples OUT.csv OUT.mcap   RobotLogWriter and RobotLogMcapWriter side by side
//   mcap_samples --augerd DIR       augerd's own log writer ([log] mcap = true) with rotation
//                                   every ~20 kB: DIR/augerd-*-N.csv, each with its .mcap
//   mcap_samples --augerd-cut DIR KIND   the same without rotation, cut short (issue 28 point 5):
//                                   kill: the process ends without closing the log (as kill -9);
//                                   reserve: the file system's free space falls below the MCAP
//                                   file's reserve; enospc: the disk is full for the MCAP file
//                                   (what it takes beyond its size at its 8th write fails)
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <thread>

#include <sys/stat.h>
#include <unistd.h>

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

bool is_mcap_fd(int fd) {
  char link[512];
  const ssize_t n = readlink(("/proc/self/fd/" + std::to_string(fd)).c_str(), link, sizeof link - 1);
  return n > 5 && std::string(link, std::size_t(n)).rfind(".mcap") == std::size_t(n) - 5;
}

int augerd_cut(const char* dir, const std::string& kind) {
  augerd::DataLogConfig c;
  c.dir = dir;
  c.run = "augerd-test";
  c.metadata = kMeta;
  c.flush_interval_s = 0.01;
  c.fsync_interval_s = 0.01;  // the MCAP file's chunk and summary with every flush
  c.mcap = true;
  std::atomic<int> mcap_writes{0}, free_calls{0};
  if (kind == "reserve")  // plenty of space for the first 8 flushes, then less than the reserve
    c.free_bytes = [&](int) -> std::uint64_t { return ++free_calls > 8 ? c.mcap_reserve_bytes - 1 : 1ull << 40; };
  std::atomic<long long> cap{-1};
  if (kind == "enospc")  // from the MCAP file's 8th write on the disk is full: its size then, plus 100 bytes
    c.write = [&](int fd, const void* b, std::size_t n) -> ssize_t {
      if (!is_mcap_fd(fd)) return ::write(fd, b, n);
      struct stat st;
      if (++mcap_writes == 8 && ::fstat(fd, &st) == 0) cap = st.st_size + 100;
      const off_t pos = ::lseek(fd, 0, SEEK_CUR);
      if (cap >= 0 && pos + off_t(n) > cap) {
        if (pos >= cap) {
          errno = ENOSPC;
          return -1;
        }
        n = std::size_t(cap - pos);
      }
      return ::write(fd, b, n);
    };
  augerd::DataLog log(c);
  log.open();
  std::vector<double> extra(augerd::replay_columns().size(), 0.25);
  samples([&](int k, const auger::RobotSample& s) {
    log.write(s, extra);
    if (k % 20 == 19) std::this_thread::sleep_for(std::chrono::milliseconds(15));
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // every row flushed
  const auto st = log.stats();
  std::printf("%llu rows, %llu lost\n", static_cast<unsigned long long>(st.rows_written),
              static_cast<unsigned long long>(st.rows_lost));
  std::fflush(stdout);
  if (kind == "kill") _exit(st.rows_written == 500 ? 0 : 1);  // no close, no summary written at exit
  log.close();
  return log.stats().rows_written == 500 && log.stats().rows_lost == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--augerd") == 0) return augerd_log(argv[2]);
  if (argc == 4 && std::strcmp(argv[1], "--augerd-cut") == 0) return augerd_cut(argv[2], argv[3]);
  if (argc == 3) return side_by_side(argv[1], argv[2]);
  std::fprintf(stderr, "usage: mcap_samples OUT.csv OUT.mcap | mcap_samples --augerd DIR\n");
  return 2;
}
