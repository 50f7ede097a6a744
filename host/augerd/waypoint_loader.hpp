// Reads a `follow` trajectory file off augerd's loop: a file read can block (a FIFO nobody
// writes, a slow disk) or take long (a big file), and the loop must not. One thread per request;
// non-regular files, files over limits::kMaxWaypointFileBytes and more than
// limits::kMaxWaypoints rows are refused; every waypoint is checked against input_limits.hpp.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "auger/trajectory.hpp"

namespace augerd {

class WaypointLoader {
 public:
  struct Result {
    std::vector<auger::Waypoint> waypoints;  // empty on error
    std::string error;                       // "" on success
    // The copy for auger replay that holds these waypoints: the one written now, or an earlier
    // one with the same contents; -1 when none (not asked for, or past the budget: why says so).
    int copy_n = -1;
    std::string copy_skipped;
  };

  // What the copies of one run may take beside the log (docs/daemon.md "Limits and abuse"): a
  // client repeating `follow` of its largest file would otherwise fill the disk. A trajectory
  // followed again is not copied again.
  static constexpr int kMaxCopies = 1000;
  static constexpr std::uint64_t kMaxCopyBytes = std::uint64_t(64) << 20;
  struct CopyBook {
    std::mutex mutex;
    std::map<std::pair<std::uint64_t, std::size_t>, int> by_contents;  // (hash, size) -> copy number
    int files = 0;
    std::uint64_t bytes = 0;
  };

  // Starts reading path (relative to augerd's working directory). If copy_path is not empty,
  // the waypoints as read are written there as copy number copy_n (CSV t_s,x_m,y_m,psi_rad;
  // docs/daemon.md "The log"), within the run's budget. One request at a time: busy() says
  // whether one is under way.
  void start(const std::string& path, const std::string& copy_path, int copy_n, double now_s);
  bool busy() const { return job_ != nullptr; }
  // The result once the file is read, or after timeout_s an error (before `auger cmd` gives up
  // at 5 s; the reading thread finishes on its own and its result is dropped). Never blocks.
  std::optional<Result> poll(double now_s, double timeout_s = 4.0);

  // The reading itself, synchronous (the thread's body; tests call it directly). Without a book
  // the copy is written unconditionally.
  static Result load(const std::string& path, const std::string& copy_path, int copy_n = 0,
                     CopyBook* book = nullptr);

 private:
  struct Job;
  std::shared_ptr<Job> job_;
  std::shared_ptr<CopyBook> book_ = std::make_shared<CopyBook>();  // shared with a thread given up on
  double started_s_ = 0;
};

}  // namespace augerd
