// Reader and writer of the measurement logs of docs/log-format.md (robot log, gantry log).
// Used by the simulator (writes both), augerd (writes the robot log) and the workbench (reads
// both, including logs other programs produced). Reading and writing stream one row at a time,
// so a long run never holds the whole log.
#pragma once

#include <array>
#include <cstdint>
#include <fstream>
#include <istream>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "auger/input_limits.hpp"
#include "auger/measured.hpp"

namespace auger {

// Every log error names the file, the 1-based line and column, and the offending text;
// what() is "file:line:column: message".
class LogError : public std::runtime_error {
 public:
  LogError(std::string file, int line, int column, const std::string& message);
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  int column() const { return column_; }
  const std::string& message() const { return message_; }

 private:
  std::string file_;
  int line_;
  int column_;
  std::string message_;
};

struct MetadataEntry {
  std::string key;
  std::string value;
  int line = 0;
};

// Generic reader: `#` lines (metadata `# key: value`), one header, rows of numbers. Columns are
// found by name; empty fields and `nan` are NaN ("not measured"); t_s must be strictly
// increasing. Unknown columns stay readable through field_text()/value().
class CsvLogReader {
 public:
  // name is what errors call the source (normally the path).
  CsvLogReader(std::istream& in, std::string name);
  explicit CsvLogReader(const std::string& path);  // throws LogError if it cannot be opened

  const std::string& name() const { return name_; }
  const std::vector<MetadataEntry>& metadata() const { return metadata_; }
  std::optional<std::string> meta(const std::string& key) const;
  const std::vector<std::string>& columns() const { return columns_; }
  int header_line() const { return header_line_; }
  // Index of a column, or -1 if the log does not have it.
  int column_index(const std::string& column) const;
  // Throws LogError (header line, column 1) naming the first missing column.
  void require_columns(const std::vector<std::string>& required) const;
  // Throws LogError if `# format:` is present and differs from expected.
  void check_format(const std::string& expected) const;
  // A metadata value as a number within bound; else LogError at its line.
  double metadata_number(const MetadataEntry& m, const InputBound& bound) const;

  // Reads the next row; false at end of file. Checks field count, numbers, t_s. A last row cut
  // short (the file ends without its newline inside the row: a full disk, a killed writer) is
  // not an error: it is dropped with a warning on stderr naming its line (last_row_cut()).
  bool next();
  bool last_row_cut() const { return last_row_cut_; }
  int line() const { return line_; }  // line of the current row
  double value(int column) const { return values_[static_cast<std::size_t>(column)]; }
  const std::string& field_text(int column) const { return fields_[static_cast<std::size_t>(column)]; }
  double t_s() const { return value(t_col_); }
  // An error at a field of the current row (for typed readers' own checks).
  [[noreturn]] void fail_at_field(int column, const std::string& message) const;

 private:
  void parse_header();
  bool read_line(std::string& line);
  bool row_is_cut(std::size_t n_fields) const;

  std::unique_ptr<std::ifstream> owned_;
  std::istream* in_;
  std::string name_;
  std::vector<MetadataEntry> metadata_;
  std::vector<std::string> columns_;
  std::unordered_map<std::string, int> column_of_;
  int header_line_ = 0;
  bool unterminated_ = false;  // the line just read ended at the end of the file, without '\n'
  bool last_row_cut_ = false;
  int line_ = 0;
  int t_col_ = -1;
  double last_t_s_ = -std::numeric_limits<double>::infinity();
  std::vector<std::string> fields_;
  std::vector<int> field_start_col_;
  std::vector<double> values_;
  std::string text_;
};

// Generic writer: metadata lines first, then the header, then rows as they come (flushable).
// Numbers are written in the shortest form that reads back to the same double; NaN is empty.
class CsvLogWriter {
 public:
  CsvLogWriter(std::ostream& out, const std::vector<std::pair<std::string, std::string>>& metadata,
               const std::vector<std::string>& columns);
  // Writes one row; values.size() must equal the number of columns and the t_s column (if
  // any) must increase strictly; throws std::invalid_argument otherwise.
  void write_row(const double* values, std::size_t count);
  void flush() { out_->flush(); }
  const std::vector<std::string>& columns() const { return columns_; }

 private:
  std::ostream* out_;
  std::vector<std::string> columns_;
  int t_col_ = -1;
  double last_t_s_ = -std::numeric_limits<double>::infinity();
  std::string row_;
};

// Appends the shortest round-trip text of value (nothing for NaN).
void append_number(std::string& out, double value);

// ---- robot log: `# format: auger-robot-log v1` ----
constexpr const char* kRobotLogFormat = "auger-robot-log v1";
constexpr const char* kGantryLogFormat = "auger-gantry-log v1";

// One robot-log sample; NaN (or an empty optional) = not measured at this sample.
struct RobotSample {
  double t_s = kNotMeasured;
  std::array<double, 4> omega_rpm{kNotMeasured, kNotMeasured, kNotMeasured, kNotMeasured};
  std::array<double, 4> cmd_rpm{kNotMeasured, kNotMeasured, kNotMeasured, kNotMeasured};
  std::array<double, 4> current_a{kNotMeasured, kNotMeasured, kNotMeasured, kNotMeasured};
  std::array<double, 4> voltage_v{kNotMeasured, kNotMeasured, kNotMeasured, kNotMeasured};
  std::array<double, 4> pwm{kNotMeasured, kNotMeasured, kNotMeasured, kNotMeasured};
  std::array<std::optional<std::int64_t>, 4> status{};
  std::array<std::optional<std::int64_t>, 4> seq_ack{};
  double x_m = kNotMeasured, y_m = kNotMeasured, psi_rad = kNotMeasured;
  double imu_psi_rad = kNotMeasured, imu_r_radps = kNotMeasured;
  double xd_m = kNotMeasured, yd_m = kNotMeasured, psid_rad = kNotMeasured;
  double loop_dt_s = kNotMeasured;
  double imu_ax_mps2 = kNotMeasured, imu_ay_mps2 = kNotMeasured;  // the IMU's body-frame specific force
};

// All robot-log column names in the order the writer uses.
const std::vector<std::string>& robot_log_columns();
// A sample as the values of robot_log_columns() followed by extra (the row RobotLogWriter
// writes; RobotLogMcapWriter writes the same). row is resized, so a reused one never allocates.
void robot_log_row(const RobotSample& sample, const std::vector<double>& extra, std::vector<double>& row);

class RobotLogReader {
 public:
  explicit RobotLogReader(const std::string& path);
  RobotLogReader(std::istream& in, std::string name);
  bool next(RobotSample& sample);
  // The underlying reader: metadata, unknown columns (extra_columns()) of the current row.
  const CsvLogReader& csv() const { return csv_; }
  // Indices of the columns this reader does not know (kept, not interpreted).
  const std::vector<int>& extra_columns() const { return extra_; }

 private:
  void bind();
  CsvLogReader csv_;
  std::vector<int> index_;  // per robot_log_columns() entry, -1 if absent
  std::vector<int> extra_;
};

class RobotLogWriter {
 public:
  // metadata should start with format; it is added if missing. extra_columns are appended
  // after the standard ones and written from write()'s extra values.
  RobotLogWriter(std::ostream& out, std::vector<std::pair<std::string, std::string>> metadata,
                 const std::vector<std::string>& extra_columns = {});
  void write(const RobotSample& sample, const std::vector<double>& extra = {});
  void flush() { csv_.flush(); }

 private:
  CsvLogWriter csv_;
  std::size_t n_extra_;
  std::vector<double> row_;
};

// ---- gantry log: `# format: auger-gantry-log v1` ----
struct GantrySample {
  double t_s = kNotMeasured;
  std::array<double, 2> omega_rpm{kNotMeasured, kNotMeasured};
  double force_n = kNotMeasured;
  double position_m = kNotMeasured;
};

// The gantry log's metadata, parsed and checked once by the reader, so that every tool reads a
// file the same way.
struct GantryMetadata {
  std::string axis;               // "longitudinal" or "lateral"; "" when the log has no `# axis:`
  std::string terrain;            // "" when absent
  std::optional<double> mass_kg;  // module plus load, within input_limits' bounds; absent: none given
};

class GantryLogReader {
 public:
  explicit GantryLogReader(const std::string& path);
  GantryLogReader(std::istream& in, std::string name);
  bool next(GantrySample& sample);
  const CsvLogReader& csv() const { return csv_; }
  const GantryMetadata& metadata() const { return meta_; }
  // The rail's axis; a log without `# axis:` is refused (LogError at the header line): which of
  // sigma_long or sigma_lat the log measures is not guessed.
  const std::string& axis() const;

 private:
  void bind();
  CsvLogReader csv_;
  GantryMetadata meta_;
  std::array<int, 5> index_{};
};

class GantryLogWriter {
 public:
  GantryLogWriter(std::ostream& out, std::vector<std::pair<std::string, std::string>> metadata);
  void write(const GantrySample& sample);
  void flush() { csv_.flush(); }

 private:
  CsvLogWriter csv_;
};

}  // namespace auger
