// augerd's logs, written off the loop (data_log.hpp).
#include "data_log.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <stdexcept>

#include <fcntl.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include "clock.hpp"

namespace augerd {
namespace {

// Data and event files: readable by the group (the operators), nobody else.
constexpr mode_t kFileMode = 0640;

}  // namespace

DataLog::DataLog(DataLogConfig config) : cfg_(std::move(config)) {
  if (!cfg_.write) cfg_.write = [](int fd, const void* b, std::size_t n) { return ::write(fd, b, n); };
  if (!cfg_.free_bytes)
    cfg_.free_bytes = [](int fd) -> std::uint64_t {
      struct statvfs v;
      return ::fstatvfs(fd, &v) == 0 ? std::uint64_t(v.f_bavail) * v.f_frsize : ~std::uint64_t(0);
    };
}

DataLog::~DataLog() { close(); }

std::vector<std::string> DataLog::columns() const {
  std::vector<std::string> c = replay_columns();
  c.insert(c.end(), cfg_.more_columns.begin(), cfg_.more_columns.end());
  return c;
}

void DataLog::open() {
  formatter_ = std::make_unique<auger::RobotLogWriter>(row_text_, cfg_.metadata, columns());
  header_ = row_text_.str();
  row_text_.str("");
  events_path_ = cfg_.dir + "/" + cfg_.run + "-events.log";
  events_fd_ = ::open(events_path_.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, kFileMode);
  if (events_fd_ < 0)
    throw std::runtime_error("cannot create the event log " + events_path_ + ": " + std::strerror(errno));
  const std::string head =
      "# auger event log v1: wall-clock UTC, t_s (the data log's clock), module, port, event, action\n";
  std::size_t w = 0;
  write_all(events_fd_, head, w);
  if (!start_file(clock_s(CLOCK_MONOTONIC)))
    throw std::runtime_error("cannot create the log file " + path_ + ": " + std::strerror(errno));
  first_path_ = path_;
  thread_ = std::thread(&DataLog::run, this);
}

void DataLog::write(const auger::RobotSample& sample, const std::vector<double>& extra) {
  if (!formatter_) return;
  formatter_->write(sample, extra);
  const std::string row = row_text_.str();
  row_text_.str("");
  std::lock_guard<std::mutex> lock(mutex_);
  if (queued_rows_.size() + row.size() > cfg_.max_queued_bytes) {
    ++dropped_full_queue_;  // the disk has not taken a row for a long time: counted as lost
    return;
  }
  queued_rows_ += row;
  if (cfg_.mcap) queued_samples_.push_back({sample, extra});
}

void DataLog::event(const std::string& line) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queued_events_ += line;
    queued_events_ += '\n';
  }
  wake_.notify_one();
}

void DataLog::close() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

DataLog::Stats DataLog::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  Stats s = stats_;
  s.rows_lost += dropped_full_queue_;
  return s;
}

std::vector<std::string> DataLog::files() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return files_;
}

bool DataLog::write_all(int fd, const std::string& data, std::size_t& written) {
  written = 0;
  while (written < data.size()) {
    const ssize_t n = cfg_.write(fd, data.data() + written, data.size() - written);
    if (n > 0) {
      written += std::size_t(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n == 0) errno = EIO;
    return false;
  }
  return true;
}

void DataLog::start_mcap() {
  // The CSV file is the record; an MCAP file that cannot be written is reported and skipped.
  mcap_path_ = path_.substr(0, path_.size() - 4) + ".mcap";
  if (cfg_.free_bytes(fd_) < cfg_.mcap_reserve_bytes) {
    std::fprintf(stderr, "augerd: less than %llu MiB free: no MCAP file beside %s (the CSV file goes first)\n",
                 static_cast<unsigned long long>(cfg_.mcap_reserve_bytes >> 20), path_.c_str());
    return;
  }
  mcap_fd_ = ::open(mcap_path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, kFileMode);
  if (mcap_fd_ < 0) {
    std::fprintf(stderr, "augerd: cannot create %s (%s); this CSV file has no MCAP file beside it\n",
                 mcap_path_.c_str(), std::strerror(errno));
    return;
  }
  mcap_sink_.str("");
  mcap_data_end_ = 0;
  mcap_tail_.clear();
  mcap_ = std::make_unique<auger::RobotLogMcapWriter>(mcap_sink_, cfg_.metadata,
                                                      auger::RobotLogMcapWriter::RobotColumnsAnd{columns()});
  mcap_->flush();
  if (!mcap_write(false)) end_mcap(false);  // complete from the start: header, schemas, channels, summary
  mcap_checkpoint_s_ = synced_at_s_;
}

bool DataLog::mcap_write(bool final) {
  std::string bytes = mcap_sink_.str();
  mcap_sink_.str("");
  const std::size_t data = bytes.size();
  if (!final) bytes += mcap_->tail();
  // The CSV file goes first: the MCAP file ends (as its last summary left it) before it could
  // take the space the CSV rows need.
  if (!final && cfg_.free_bytes(mcap_fd_) < cfg_.mcap_reserve_bytes + bytes.size()) {
    std::fprintf(stderr,
                 "augerd: less than %llu MiB free: the MCAP file %s ends here, complete; the CSV file goes on\n",
                 static_cast<unsigned long long>(cfg_.mcap_reserve_bytes >> 20), mcap_path_.c_str());
    return false;
  }
  std::size_t written = 0;
  if (::lseek(mcap_fd_, off_t(mcap_data_end_), SEEK_SET) >= 0 && write_all(mcap_fd_, bytes, written) &&
      ::ftruncate(mcap_fd_, off_t(mcap_data_end_ + bytes.size())) == 0) {
    mcap_data_end_ += data;
    mcap_tail_ = bytes.substr(data);
    return true;
  }
  // Undo: the file as the last flush left it (cutting it back frees what the new bytes took).
  const int err = errno;
  std::size_t w = 0;
  const bool undone = ::ftruncate(mcap_fd_, off_t(mcap_data_end_)) == 0 &&
                      ::lseek(mcap_fd_, off_t(mcap_data_end_), SEEK_SET) >= 0 && write_all(mcap_fd_, mcap_tail_, w);
  std::fprintf(stderr, "augerd: %s: writing failed (%s); %s; the CSV file goes on\n", mcap_path_.c_str(),
               std::strerror(err),
               undone ? "the MCAP file ends at its last flush, complete" : "the MCAP file may be cut short");
  return false;
}

void DataLog::end_mcap(bool finish) {
  if (!mcap_) return;
  if (finish) {
    mcap_->finish();  // the last chunk and the summary, into the sink
    mcap_write(true);
  }
  mcap_.reset();
  mcap_sink_.str("");
  ::close(mcap_fd_);
  mcap_fd_ = -1;
}

bool DataLog::start_file(double now_s) {
  char stamp[32];
  const std::time_t now = std::time(nullptr);
  std::tm tm_utc;
  gmtime_r(&now, &tm_utc);
  std::strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &tm_utc);
  path_ = cfg_.dir + "/augerd-" + stamp + "-" + std::to_string(index_++) + ".csv";
  const int fd = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, kFileMode);
  if (fd < 0) return false;
  std::size_t w = 0;
  if (!write_all(fd, header_, w)) {
    // A file that cannot take its header is not left behind (no empty files on every retry).
    const int err = errno;
    ::close(fd);
    ::unlink(path_.c_str());
    errno = err;
    return false;
  }
  fd_ = fd;
  size_ = header_.size();
  synced_at_s_ = now_s;
  if (cfg_.mcap) start_mcap();
  std::lock_guard<std::mutex> lock(mutex_);
  files_.push_back(path_);
  ++stats_.files;
  stats_.ok = true;
  return true;
}

void DataLog::fail(const char* what, int err, double now_s) {
  end_mcap(false);  // complete as the last flush left it; no more bytes for a disk that is full
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  retry_at_s_ = now_s + cfg_.retry_s;
  lost_since_failure_ = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.failures;
    stats_.ok = false;
  }
  std::fprintf(stderr,
               "augerd: log %s: %s failed (%s); the file ends at its last whole row; control goes on without the "
               "log, a new file is tried every %g s\n",
               path_.c_str(), what, std::strerror(err), cfg_.retry_s);
}

void DataLog::sync(double now_s) {
  if (fd_ < 0) return;
  const double t0 = clock_s(CLOCK_MONOTONIC);
  ::fdatasync(fd_);
  if (mcap_fd_ >= 0) ::fdatasync(mcap_fd_);
  const double dt = clock_s(CLOCK_MONOTONIC) - t0;
  synced_at_s_ = now_s;
  std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.fsyncs;
  stats_.fsync_total_s += dt;
  stats_.fsync_max_s = std::max(stats_.fsync_max_s, dt);
}

void DataLog::write_rows(const std::string& rows, const std::vector<Sample>& samples, double now_s) {
  // The rows of one flush, split where the file reaches rotate_bytes: a file ends with the first
  // row at or beyond that size, as when the loop wrote every row itself.
  std::size_t row = 0;
  for (std::size_t begin = 0; begin < rows.size();) {
    std::size_t end = rows.size();
    if (fd_ >= 0 && size_ < cfg_.rotate_bytes && cfg_.rotate_bytes - size_ < end - begin) {
      const std::size_t nl = rows.find('\n', begin + std::size_t(cfg_.rotate_bytes - size_) - 1);
      if (nl != std::string::npos) end = nl + 1;
    }
    const std::string chunk = rows.substr(begin, end - begin);
    const auto n = std::size_t(std::count(chunk.begin(), chunk.end(), '\n'));
    write_chunk(chunk, n, row + n <= samples.size() ? samples.data() + row : nullptr, now_s);
    row += n;
    begin = end;
  }
}

void DataLog::write_chunk(const std::string& rows, std::size_t n_rows, const Sample* samples, double now_s) {
  if (n_rows == 0) return;
  auto lost = [&](std::uint64_t n) {
    lost_since_failure_ += n;
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.rows_lost += n;
  };
  if (fd_ < 0) {
    if (now_s < retry_at_s_) return lost(n_rows);
    if (!start_file(now_s)) {
      retry_at_s_ = now_s + cfg_.retry_s;
      return lost(n_rows);
    }
    std::fprintf(stderr, "augerd: logging again, to %s (%llu rows were not logged)\n", path_.c_str(),
                 static_cast<unsigned long long>(lost_since_failure_));
  }
  std::size_t written = 0;
  if (!write_all(fd_, rows, written)) {
    const int err = errno;
    // Cut the file back to the last whole row it received: readers never see half a row.
    const std::size_t nl = written ? rows.rfind('\n', written - 1) : std::string::npos;
    const std::size_t keep = nl == std::string::npos ? 0 : nl + 1;
    if (written != keep && ::ftruncate(fd_, off_t(size_ + keep)) != 0)
      std::fprintf(stderr, "augerd: log %s: cannot cut the last row back (%s)\n", path_.c_str(), std::strerror(errno));
    const auto kept_rows = std::uint64_t(std::count(rows.begin(), rows.begin() + std::ptrdiff_t(keep), '\n'));
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stats_.rows_written += kept_rows;
    }
    fail("write", err, now_s);
    lost(n_rows - kept_rows);
    return;
  }
  size_ += rows.size();
  if (mcap_ && samples) {
    for (std::size_t k = 0; k < n_rows; ++k) mcap_->write(samples[k].sample, samples[k].extra);
    // A chunk and a new summary every fsync interval (what a crash may lose of the MCAP file;
    // the CSV file, the record, loses at most a flush interval): the summary grows with the
    // chunks, and writing it every second would write more than the rows on an SD card.
    if (now_s - mcap_checkpoint_s_ >= cfg_.fsync_interval_s) {
      mcap_checkpoint_s_ = now_s;
      mcap_->flush();
      if (!mcap_write(false)) end_mcap(false);
    }
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.rows_written += n_rows;
  }
  if (size_ >= cfg_.rotate_bytes) {
    end_mcap();
    sync(now_s);
    ::close(fd_);
    fd_ = -1;
    if (!start_file(now_s)) fail("rotation", errno, now_s);
  }
}

void DataLog::run() {
  for (;;) {
    std::string rows, events;
    std::vector<Sample> samples;
    bool stopping;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait_for(lock, std::chrono::duration<double>(cfg_.flush_interval_s),
                     [&] { return stop_ || !queued_events_.empty(); });
      rows.swap(queued_rows_);
      samples.swap(queued_samples_);
      events.swap(queued_events_);
      stopping = stop_;
    }
    const double now = clock_s(CLOCK_MONOTONIC);
    if (!events.empty() && events_fd_ >= 0) {
      // A fault is what one reads after a crash or a power cut: written and synced at once.
      std::size_t w = 0;
      if (write_all(events_fd_, events, w)) ::fdatasync(events_fd_);
    }
    write_rows(rows, samples, now);
    if (fd_ >= 0 && now - synced_at_s_ >= cfg_.fsync_interval_s) sync(now);
    if (stopping) break;
  }
  end_mcap();
  sync(clock_s(CLOCK_MONOTONIC));
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  if (events_fd_ >= 0) {
    ::fdatasync(events_fd_);
    ::close(events_fd_);
  }
  events_fd_ = -1;
}

}  // namespace augerd
