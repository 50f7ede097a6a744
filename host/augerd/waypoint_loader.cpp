// `follow` files read off the loop (waypoint_loader.hpp).
#include "waypoint_loader.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <sstream>
#include <thread>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "auger/input_limits.hpp"
#include "daemon_lines.hpp"

namespace augerd {

struct WaypointLoader::Job {
  std::mutex mutex;
  bool done = false;
  Result result;
};

namespace {

WaypointLoader::Result failed(const std::string& path, const std::string& why) {
  WaypointLoader::Result r;
  r.error = auger::daemon::quote_line(path) + ": " + why;
  return r;
}

}  // namespace

WaypointLoader::Result WaypointLoader::load(const std::string& path, const std::string& copy_path) {
  using auger::limits::kMaxWaypointFileBytes;
  using auger::limits::kMaxWaypoints;
  // O_NONBLOCK: opening a FIFO with no writer returns at once (then refused as not regular).
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) return failed(path, std::string("cannot open: ") + std::strerror(errno));
  struct stat st;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return failed(path, "not a regular file (a FIFO, a device or a directory is refused)");
  }
  if (std::uint64_t(st.st_size) > kMaxWaypointFileBytes) {
    ::close(fd);
    return failed(path, std::to_string(st.st_size) + " bytes, more than the " +
                            std::to_string(kMaxWaypointFileBytes >> 20) + " MiB a waypoint file may have");
  }
  std::string text;
  text.resize(kMaxWaypointFileBytes + 1);
  std::size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = ::read(fd, &text[got], text.size() - got);
    if (n > 0) {
      got += std::size_t(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int err = errno;
      ::close(fd);
      return failed(path, std::string("read failed: ") + std::strerror(err));
    }
    break;
  }
  ::close(fd);
  if (got > kMaxWaypointFileBytes) return failed(path, "grew beyond the size a waypoint file may have while read");
  text.resize(got);
  Result r;
  try {
    std::istringstream in(text);
    r.waypoints = auger::read_waypoints_csv(in, path, kMaxWaypoints);
    auger::check_waypoints(r.waypoints);
  } catch (const std::exception& e) {
    return failed(path, e.what());
  }
  if (r.waypoints.empty()) return failed(path, "no waypoints");
  for (std::size_t i = 0; i < r.waypoints.size(); ++i) {
    const auto& w = r.waypoints[i];
    const std::string e = auger::check_waypoint(i, w.t_s, w.eta_p[0], w.eta_p[1], w.eta_p[2]);
    if (!e.empty()) return failed(path, e);
  }
  if (!copy_path.empty()) {
    if (std::FILE* f = std::fopen(copy_path.c_str(), "w")) {
      std::fprintf(f, "t_s,x_m,y_m,psi_rad\n");
      for (const auto& w : r.waypoints)
        std::fprintf(f, "%.17g,%.17g,%.17g,%.17g\n", w.t_s, w.eta_p[0], w.eta_p[1], w.eta_p[2]);
      r.copied = std::fclose(f) == 0;
    }
  }
  return r;
}

void WaypointLoader::start(const std::string& path, const std::string& copy_path, double now_s) {
  auto job = std::make_shared<Job>();
  job_ = job;
  started_s_ = now_s;
  std::thread([job, path, copy_path] {
    Result r = load(path, copy_path);
    std::lock_guard<std::mutex> lock(job->mutex);
    job->result = std::move(r);
    job->done = true;
  }).detach();
}

std::optional<WaypointLoader::Result> WaypointLoader::poll(double now_s, double timeout_s) {
  if (!job_) return std::nullopt;
  {
    std::unique_lock<std::mutex> lock(job_->mutex, std::try_to_lock);
    if (lock.owns_lock() && job_->done) {
      Result r = std::move(job_->result);
      lock.unlock();
      job_.reset();
      return r;
    }
  }
  if (now_s - started_s_ < timeout_s) return std::nullopt;
  job_.reset();  // the thread finishes on its own; its result is dropped
  Result r;
  r.error = "the waypoint file was still being read after " + std::to_string(int(timeout_s)) + " s; given up";
  return r;
}

}  // namespace augerd
