// augerd's log writer (data_log.hpp) with a full disk injected into its write(2), and the
// `follow` file reader (waypoint_loader.hpp) on the files that froze the loop before: a FIFO
// nobody writes, /dev/zero, a file too big, too many rows, absurd values.
#include <catch2/catch.hpp>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <dirent.h>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <thread>
#include <unistd.h>
#include <vector>

#include "auger/input_limits.hpp"
#include "auger/log.hpp"
#include "data_log.hpp"
#include "waypoint_loader.hpp"

using namespace augerd;

namespace {

struct TempDir {
  std::string path;
  TempDir() {
    char t[] = "/tmp/augerd-log-XXXXXX";
    REQUIRE(mkdtemp(t));
    path = t;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

std::vector<std::string> csv_files(const std::string& dir) {
  std::vector<std::string> out;
  DIR* d = opendir(dir.c_str());
  while (dirent* e = readdir(d)) {
    const std::string n = e->d_name;
    if (n.size() > 4 && n.substr(n.size() - 4) == ".csv") out.push_back(dir + "/" + n);
  }
  closedir(d);
  return out;
}

std::string slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// A disk that takes `room` more bytes, then fails like a full one (ENOSPC), the last write short.
struct FullDisk {
  std::mutex m;
  long room = 1 << 30;
  ssize_t write(int fd, const void* b, std::size_t n) {
    std::lock_guard<std::mutex> lock(m);
    if (room <= 0) {
      errno = ENOSPC;
      return -1;
    }
    const std::size_t k = std::min<std::size_t>(n, std::size_t(room));
    const ssize_t w = ::write(fd, b, k);
    if (w > 0) room -= w;
    return w;
  }
  void set(long r) {
    std::lock_guard<std::mutex> lock(m);
    room = r;
  }
};

auger::RobotSample sample(double t) {
  auger::RobotSample s;
  s.t_s = t;
  for (int i = 0; i < 4; ++i) s.omega_rpm[std::size_t(i)] = 10.0 + i + t, s.cmd_rpm[std::size_t(i)] = 12.0;
  s.x_m = t * 0.01;
  s.loop_dt_s = 0.01;
  return s;
}

// Rows in a data file, checked whole by the project's reader (which warns about a cut last row).
int whole_rows(const std::string& path) {
  auger::RobotLogReader r(path);
  auger::RobotSample s;
  int n = 0;
  while (r.next(s)) ++n;
  CHECK_FALSE(r.csv().last_row_cut());
  return n;
}

}  // namespace

TEST_CASE("a full disk leaves whole rows, no empty files, and the log comes back", "[daemon][unit]") {
  TempDir dir;
  FullDisk disk;
  DataLogConfig c;
  c.dir = dir.path;
  c.run = "augerd-test";
  c.metadata = {{"format", auger::kRobotLogFormat}, {"terrain", "sand"}};
  c.flush_interval_s = 0.01;
  c.retry_s = 0.05;
  c.write = [&](int fd, const void* b, std::size_t n) { return disk.write(fd, b, n); };
  DataLog log(c);
  log.open();
  const std::vector<double> extra(replay_columns().size(), 1.5);
  double t = 0;
  auto rows = [&](int n) {
    for (int k = 0; k < n; ++k) {
      t += 0.01;
      log.write(sample(t), extra);
      if (k % 10 == 9) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(60));
  };
  rows(100);
  // The disk fills in the middle of a row: 1000 more bytes.
  disk.set(1000);
  rows(100);
  CHECK_FALSE(log.stats().ok);
  // Retries while the disk is still full: a new file cannot take its header, and is removed.
  disk.set(0);
  rows(100);
  CHECK(csv_files(dir.path).size() == 1);
  // Room again: a new file, whole rows (however slow this machine is today).
  disk.set(1 << 30);
  int written_after = 0;
  for (int k = 0; k < 100 && (written_after < 100 || !log.stats().ok); ++k) rows(10), written_after += 10;
  log.close();
  const DataLog::Stats st = log.stats();
  CHECK(st.ok);
  CHECK(st.failures == 1);
  const auto files = csv_files(dir.path);
  REQUIRE(files.size() == 2);
  int total = 0;
  for (const auto& f : files) {
    const std::string text = slurp(f);
    INFO(f);
    CHECK(!text.empty());
    CHECK(text.back() == '\n');  // ends at a row boundary
    total += whole_rows(f);
  }
  CHECK(std::uint64_t(total) == st.rows_written);
  CHECK(st.rows_written + st.rows_lost == std::uint64_t(300 + written_after));
  CHECK(st.rows_lost >= 100);  // everything while the disk was full
  CHECK(st.fsyncs >= 1);       // the new file at close (the failed one was not synced)
}

TEST_CASE("the log rotates at its size and syncs on the interval", "[daemon][unit]") {
  TempDir dir;
  DataLogConfig c;
  c.dir = dir.path;
  c.run = "augerd-test";
  c.metadata = {{"format", auger::kRobotLogFormat}};
  c.flush_interval_s = 0.01;
  c.fsync_interval_s = 0.02;
  c.rotate_bytes = 20000;
  DataLog log(c);
  log.open();
  const std::vector<double> extra(replay_columns().size(), 0.0);
  for (int k = 1; k <= 600; ++k) {
    log.write(sample(0.01 * k), extra);
    if (k % 20 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  log.event("an event line");
  log.close();
  const auto files = csv_files(dir.path);
  CHECK(files.size() >= 3);
  int total = 0;
  for (const auto& f : files) total += whole_rows(f);
  CHECK(total == 600);
  CHECK(log.stats().fsyncs >= 3);
  CHECK(slurp(log.events_path()).find("an event line\n") != std::string::npos);
}

TEST_CASE("follow files: nothing blocks, big or absurd files are refused", "[daemon][unit]") {
  TempDir dir;
  const std::string fifo = dir.path + "/fifo";
  REQUIRE(mkfifo(fifo.c_str(), 0600) == 0);
  const auto t0 = std::chrono::steady_clock::now();
  auto r = WaypointLoader::load(fifo, "");
  CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 1.0);
  CHECK(r.error.find("not a regular file") != std::string::npos);
  CHECK(WaypointLoader::load("/dev/zero", "").error.find("not a regular file") != std::string::npos);
  CHECK(WaypointLoader::load(dir.path, "").error.find("not a regular file") != std::string::npos);
  CHECK(WaypointLoader::load(dir.path + "/none.csv", "").error.find("cannot open") != std::string::npos);
  {
    const std::string big = dir.path + "/big.csv";
    const int fd = open(big.c_str(), O_WRONLY | O_CREAT, 0644);
    REQUIRE(ftruncate(fd, off_t(auger::limits::kMaxWaypointFileBytes) + 1) == 0);  // sparse: nothing read
    close(fd);
    CHECK(WaypointLoader::load(big, "").error.find("more than the 8 MiB") != std::string::npos);
  }
  {
    const std::string many = dir.path + "/many.csv";
    std::ofstream f(many);
    f << "t_s,x_m,y_m,psi_rad\n";
    for (std::size_t k = 0; k <= auger::limits::kMaxWaypoints; ++k) f << k << ",0,0,0\n";
    f.close();
    CHECK(WaypointLoader::load(many, "").error.find("more than 100000 waypoints") != std::string::npos);
  }
  for (const char* row : {"1,1e308,0,0", "1,0,0,1e300", "1e9,0,0,0", "-1,0,0,0"}) {
    const std::string p = dir.path + "/absurd.csv";
    std::ofstream(p) << "t_s,x_m,y_m,psi_rad\n" << row << "\n";
    INFO(row);
    CHECK(WaypointLoader::load(p, "").error.find("is outside") != std::string::npos);
  }
  {
    const std::string p = dir.path + "/ok.csv", copy = dir.path + "/copy.waypoints";
    std::ofstream(p) << "# a square\nt_s,x_m,y_m,psi_rad\n0,0,0,0\n5,0.5,0,0\n10,0.5,0.5,1.57\n";
    r = WaypointLoader::load(p, copy, 7);
    CHECK(r.error.empty());
    CHECK(r.waypoints.size() == 3);
    CHECK(r.copy_n == 7);
    CHECK(slurp(copy).rfind("t_s,x_m,y_m,psi_rad\n0,0,0,0\n5,0.5,0,0\n", 0) == 0);
  }
  {  // issue 28 point 4: a client repeating follow filled the disk with copies (394 MB in 10 s)
    WaypointLoader::CopyBook book;
    const std::string a = dir.path + "/a.csv", b = dir.path + "/b.csv";
    std::ofstream(a) << "t_s,x_m,y_m,psi_rad\n0,0,0,0\n5,0.5,0,0\n";
    {
      std::ofstream f(b);
      f << "t_s,x_m,y_m,psi_rad\n";
      for (int k = 0; k < 100000; ++k) f << k * 0.01 << ",0.123456789,0.987654321,0.5\n";
    }
    auto copy_of = [&](int n) { return dir.path + "/c-" + std::to_string(n) + ".waypoints"; };
    int n = 0;
    CHECK(WaypointLoader::load(a, copy_of(n), n, &book).copy_n == 0);
    ++n;
    // The same trajectory again: the earlier copy, no new file.
    CHECK(WaypointLoader::load(a, copy_of(n), n, &book).copy_n == 0);
    CHECK(access(copy_of(n).c_str(), F_OK) != 0);
    // Distinct large trajectories until the budget is spent: then followed, not copied.
    std::string skipped;
    for (int k = 0; k < 40 && skipped.empty(); ++k) {
      std::ofstream f(b);
      f << "t_s,x_m,y_m,psi_rad\n";
      for (int i = 0; i < 100000; ++i) f << i * 0.01 + k << ",0.123456789,0.987654321,0.5\n";
      f.close();
      ++n;
      const auto got = WaypointLoader::load(b, copy_of(n), n, &book);
      CHECK(got.error.empty());
      CHECK(got.waypoints.size() == 100000);
      skipped = got.copy_skipped;
      if (skipped.empty()) CHECK(got.copy_n == n);
      else CHECK(got.copy_n == -1);
    }
    INFO(skipped);
    CHECK(skipped.find("no copy, auger replay cannot rerun this follow") != std::string::npos);
    CHECK(book.bytes <= WaypointLoader::kMaxCopyBytes);
    std::uint64_t on_disk = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir.path))
      if (e.path().extension() == ".waypoints") on_disk += e.file_size();
    CHECK(on_disk <= WaypointLoader::kMaxCopyBytes + 4096);
  }
  {  // through the thread: poll() never blocks, the FIFO's answer comes
    WaypointLoader l;
    l.start(fifo, "", 0, 0.0);
    std::optional<WaypointLoader::Result> got;
    for (int k = 0; k < 200 && !got; ++k) {
      got = l.poll(0.01 * k);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    REQUIRE(got);
    CHECK(got->error.find("not a regular file") != std::string::npos);
    CHECK_FALSE(l.busy());
  }
}
