// augerd's robot log and fault event log, written by a thread of their own so that a slow or
// full disk never holds the 100 Hz loop (docs/daemon.md "The log", "Limits and abuse"):
// - the loop formats each row and queues it (never blocks on the disk); the writer thread
//   writes whole rows every flush interval, so a crash loses at most that much;
// - a file ends at a row boundary whatever happens: a short write is cut back to its last whole
//   row (ftruncate);
// - a full disk (ENOSPC, EFBIG, EIO, ...) closes the file there, reports once, drops rows until a
//   new file can be started (tried every retry_s; a new file that cannot take its header is
//   removed, so retries leave no empty files), and says how many rows were lost;
// - fdatasync every fsync_interval_s, at rotation and at the end (what a power cut may lose),
//   with the time each took;
// - optionally an MCAP file beside each CSV file (same rows, same name with .mcap; docs/formats.md
//   "MCAP"), written by the same thread after the CSV file, complete (summary and footer) after
//   every fsync interval: the interval's chunk goes where the last summary began, followed by
//   the new summary, so a kill leaves a file every reader opens; a write that fails (a full disk) is
//   undone (the file cut back and its last summary written again) and the MCAP file ends there;
//   and it gives way to the CSV file: below mcap_reserve_bytes free it ends (the CSV goes on).
#pragma once

#include <sys/types.h>

#include <condition_variable>
#include <fstream>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "auger/log.hpp"
#include "auger/log_mcap.hpp"
#include "daemon_log.hpp"

namespace augerd {

using auger::daemon::replay_columns;  // the columns after docs/log-format.md's

struct DataLogConfig {
  std::string dir;
  std::string run;  // augerd-<UTC start>: names the files of this run
  std::vector<std::pair<std::string, std::string>> metadata;
  std::uint64_t rotate_bytes = 64ull << 20;
  double flush_interval_s = 1.0;
  double fsync_interval_s = 10.0;
  double retry_s = 10.0;                     // a new file after a write error, this often
  std::size_t max_queued_bytes = 16u << 20;  // rows waiting for the disk beyond this are dropped
  bool mcap = false;                         // an MCAP file beside each CSV file
  // The columns after the replay columns (the online estimate's, when [online] enabled); the
  // extra values of write() are the replay columns' then these.
  std::vector<std::string> more_columns;
  // The system call that writes (tests inject a full disk here).
  std::function<ssize_t(int fd, const void* buf, std::size_t n)> write = nullptr;
  // The MCAP file is written only while the file system keeps this much free for the CSV file
  // (64 MiB: half an hour of CSV rows at 100 Hz); free_bytes tells (tests inject a full disk).
  std::uint64_t mcap_reserve_bytes = 64ull << 20;
  std::function<std::uint64_t(int fd)> free_bytes = nullptr;
};

class DataLog {
 public:
  explicit DataLog(DataLogConfig config);
  ~DataLog();  // close()
  DataLog(const DataLog&) = delete;
  DataLog& operator=(const DataLog&) = delete;

  // Creates the first data file and the event log, starts the writer thread. Throws
  // std::runtime_error naming the file.
  void open();
  // From the loop: formats the row and queues it. Never waits for the disk.
  void write(const auger::RobotSample& sample, const std::vector<double>& extra);
  // One line of the event log (no newline); written and synced at once by the writer thread.
  void event(const std::string& line);
  // Writes what is queued, syncs, closes, joins the thread.
  void close();
  std::vector<std::string> columns() const;  // after docs/log-format.md's: replay_columns() then more_columns

  struct Stats {
    std::uint64_t rows_written = 0, rows_lost = 0, files = 0, failures = 0;
    std::uint64_t fsyncs = 0;
    double fsync_max_s = 0, fsync_total_s = 0;
    bool ok = true;  // writing now
  };
  Stats stats() const;
  std::string first_path() const { return first_path_; }
  std::string events_path() const { return events_path_; }
  // The data files written so far, in order.
  std::vector<std::string> files() const;

 private:
  void run();
  bool start_file(double now_s);  // writer thread; false: could not (and nothing left behind)
  struct Sample {
    auger::RobotSample sample;
    std::vector<double> extra;
  };
  // rows and, with MCAP, their samples (one per row, in the same order)
  void write_rows(const std::string& rows, const std::vector<Sample>& samples, double now_s);
  void write_chunk(const std::string& rows, std::size_t n_rows, const Sample* samples, double now_s);
  void start_mcap();
  // finish: write the last chunk and the summary; else the file stays as its last flush left it.
  void end_mcap(bool finish = true);
  bool mcap_write(bool final);  // the sink's bytes and (unless final) a new summary, at the data's end
  void fail(const char* what, int err, double now_s);
  bool write_all(int fd, const std::string& data, std::size_t& written);
  void sync(double now_s);

  DataLogConfig cfg_;
  std::string header_;               // metadata and header row, written at the top of every file
  std::ostringstream row_text_;       // the loop's formatter
  std::unique_ptr<auger::RobotLogWriter> formatter_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::string queued_rows_, queued_events_;
  std::vector<Sample> queued_samples_;
  std::uint64_t dropped_full_queue_ = 0;
  bool stop_ = false;
  std::thread thread_;
  Stats stats_;
  std::vector<std::string> files_;

  // writer thread only
  int fd_ = -1, events_fd_ = -1;
  std::uint64_t size_ = 0;  // bytes of whole rows in the current file
  int index_ = 0;
  double retry_at_s_ = 0, synced_at_s_ = 0;
  std::uint64_t lost_since_failure_ = 0;
  std::string first_path_, events_path_, path_;
  int mcap_fd_ = -1;
  std::ostringstream mcap_sink_;     // what the MCAP writer wrote since the last mcap_write
  std::uint64_t mcap_data_end_ = 0;  // where the file's summary (mcap_tail_) begins
  double mcap_checkpoint_s_ = 0;     // when the last chunk and summary were written
  std::string mcap_tail_;
  std::unique_ptr<auger::RobotLogMcapWriter> mcap_;
  std::string mcap_path_;
};

}  // namespace augerd
