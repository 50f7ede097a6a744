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

// FNV-1a, 64 bits: tells a trajectory followed again from a new one.
std::uint64_t fnv1a(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

WaypointLoader::Result WaypointLoader::load(const std::string& path, const std::string& copy_path, int copy_n,
                                            CopyBook* book) {
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
  if (copy_path.empty()) return r;
  std::string copy = "t_s,x_m,y_m,psi_rad\n";
  char row[128];
  for (const auto& w : r.waypoints) {
    std::snprintf(row, sizeof row, "%.17g,%.17g,%.17g,%.17g\n", w.t_s, w.eta_p[0], w.eta_p[1], w.eta_p[2]);
    copy += row;
  }
  const auto key = std::make_pair(fnv1a(copy), copy.size());
  std::unique_lock<std::mutex> lock;
  if (book) {
    lock = std::unique_lock<std::mutex>(book->mutex);
    const auto same = book->by_contents.find(key);
    if (same != book->by_contents.end()) {
      r.copy_n = same->second;
      return r;
    }
    if (book->files >= kMaxCopies || book->bytes + copy.size() > kMaxCopyBytes) {
      r.copy_skipped = "the follow files of this run already take " + std::to_string(book->files) + " copies, " +
                       std::to_string(book->bytes >> 10) + " KiB beside the log (at most " +
                       std::to_string(kMaxCopies) + " and " + std::to_string(kMaxCopyBytes >> 20) +
                       " MiB): no copy, auger replay cannot rerun this follow";
      return r;
    }
  }
  if (std::FILE* f = std::fopen(copy_path.c_str(), "w")) {
    const bool ok = std::fwrite(copy.data(), 1, copy.size(), f) == copy.size();
    if (std::fclose(f) == 0 && ok) r.copy_n = copy_n;
  }
  if (r.copy_n < 0) {
    r.copy_skipped = "the copy " + copy_path + " could not be written";
    std::remove(copy_path.c_str());
  } else if (book) {
    book->by_contents[key] = copy_n;
    ++book->files;
    book->bytes += copy.size();
  }
  return r;
}

void WaypointLoader::start(const std::string& path, const std::string& copy_path, int copy_n, double now_s) {
  auto job = std::make_shared<Job>();
  job_ = job;
  started_s_ = now_s;
  std::thread([job, path, copy_path, copy_n, book = book_] {
    Result r = load(path, copy_path, copy_n, book.get());
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
