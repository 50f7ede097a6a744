// Log reader/writer of docs/log-format.md.
#include "auger/log.hpp"

#include "auger/input_limits.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <unordered_set>

#include <sys/stat.h>

namespace auger {
namespace {

std::string trim(const std::string& s, std::size_t* lead = nullptr) {
  std::size_t b = 0;
  std::size_t e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t')) --e;
  if (lead) *lead = b;
  return s.substr(b, e - b);
}

bool is_nan_text(const std::string& s) {
  if (s.size() != 3) return false;
  return (s[0] == 'n' || s[0] == 'N') && (s[1] == 'a' || s[1] == 'A') &&
         (s[2] == 'n' || s[2] == 'N');
}

// Parses a whole field as a finite double; false if it is not one.
bool parse_double(const std::string& s, double& out) {
  const char* b = s.data();
  const char* e = b + s.size();
  if (b != e && *b == '+') ++b;  // from_chars rejects a leading '+', other programs write it
  if (b == e) return false;
  auto res = std::from_chars(b, e, out);
  return res.ec == std::errc() && res.ptr == e && std::isfinite(out);
}

std::string quote(const std::string& s) { return quote_input(s); }

}  // namespace


LogError::LogError(std::string file, int line, int column, const std::string& message)
    : std::runtime_error(file + ":" + std::to_string(line) + ":" + std::to_string(column) +
                         ": " + message),
      file_(std::move(file)),
      line_(line),
      column_(column),
      message_(message) {}

void append_number(std::string& out, double value) {
  if (!measured(value)) return;
  char buf[40];
  auto res = std::to_chars(buf, buf + sizeof buf, value);  // shortest round-trip form
  out.append(buf, res.ptr);
}

// ---------------------------------------------------------------- CsvLogReader
CsvLogReader::CsvLogReader(std::istream& in, std::string name) : in_(&in), name_(std::move(name)) {
  parse_header();
}

namespace {
// A directory or a device is not a log (reading /dev/zero would never end); a pipe is fine.
const std::string& readable_file(const std::string& path) {
  struct stat st;
  if (::stat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) throw LogError(path, 0, 0, "is a directory, not a log file");
    if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) || S_ISSOCK(st.st_mode))
      throw LogError(path, 0, 0, "is a device or socket, not a log file");
  }
  return path;
}
}  // namespace

CsvLogReader::CsvLogReader(const std::string& path)
    : owned_(std::make_unique<std::ifstream>(readable_file(path))), in_(owned_.get()), name_(path) {
  if (!*owned_) throw LogError(path, 0, 0, "cannot open log file");
  parse_header();
}

bool CsvLogReader::read_line(std::string& line) {
  if (!std::getline(*in_, line)) return false;
  unterminated_ = in_->eof();  // getline stopped at the end of the file, not at a newline
  ++line_;
  if (!line.empty() && line.back() == '\r') line.pop_back();  // CRLF files
  if (line_ == 1 && line.size() >= 3 && std::memcmp(line.data(), "\xEF\xBB\xBF", 3) == 0)
    line.erase(0, 3);  // UTF-8 byte order mark
  return true;
}

void CsvLogReader::parse_header() {
  std::string line;
  for (;;) {
    if (!read_line(line)) throw LogError(name_, line_ + 1, 1, "no header row (end of file)");
    std::string t = trim(line);
    if (t.empty()) continue;
    if (t[0] == '#') {
      std::string body = trim(t.substr(1));
      auto colon = body.find(':');
      if (colon != std::string::npos && colon > 0 &&
          body.find_first_of(" \t") > colon) {  // `key: value`, key without blanks
        metadata_.push_back({trim(body.substr(0, colon)), trim(body.substr(colon + 1)), line_});
        // The format's own time key must be a clock's (merge aligns logs by it).
        if (metadata_.back().key == "t0_unix_s") metadata_number(metadata_.back(), limits::kLogTime);
      }
      continue;  // free notes are comments
    }
    break;
  }
  header_line_ = line_;
  std::size_t start = 0;
  for (;;) {
    std::size_t comma = line.find(',', start);
    std::string raw = line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    std::size_t lead = 0;
    std::string col = trim(raw, &lead);
    const int column = static_cast<int>(start + lead) + 1;
    if (col.empty()) throw LogError(name_, line_, column, "empty column name in header");
    // A hash map: a header of 100 000 columns is read in linear time.
    if (!column_of_.emplace(col, static_cast<int>(columns_.size())).second)
      throw LogError(name_, line_, column, "duplicate column " + quote(col));
    columns_.push_back(col);
    field_start_col_.push_back(column);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  t_col_ = column_index("t_s");
  if (t_col_ < 0) throw LogError(name_, header_line_, 1, "header has no column 't_s'");
  fields_.resize(columns_.size());
  values_.resize(columns_.size());
}

double CsvLogReader::metadata_number(const MetadataEntry& m, const InputBound& bound) const {
  double v = 0;
  if (!parse_double(m.value, v))
    throw LogError(name_, m.line, 1, "metadata '" + m.key + "' " + quote(m.value) + " is not a number");
  if (const std::string e = check_bound(m.key.c_str(), v, bound); !e.empty()) throw LogError(name_, m.line, 1, e);
  return v;
}

std::optional<std::string> CsvLogReader::meta(const std::string& key) const {
  for (const auto& m : metadata_)
    if (m.key == key) return m.value;
  return std::nullopt;
}

int CsvLogReader::column_index(const std::string& column) const {
  auto it = column_of_.find(column);
  return it == column_of_.end() ? -1 : it->second;
}

void CsvLogReader::require_columns(const std::vector<std::string>& required) const {
  for (const auto& c : required)
    if (column_index(c) < 0)
      throw LogError(name_, header_line_, 1, "header has no required column " + quote(c));
}

void CsvLogReader::check_format(const std::string& expected) const {
  for (const auto& m : metadata_)
    if (m.key == "format" && m.value != expected)
      throw LogError(name_, m.line, 1,
                     "format " + quote(m.value) + " where " + quote(expected) + " was expected");
}

void CsvLogReader::fail_at_field(int column, const std::string& message) const {
  throw LogError(name_, line_, field_start_col_[static_cast<std::size_t>(column)],
                 message + " in column " + quote(columns_[static_cast<std::size_t>(column)]));
}

// The file's last line, without its newline, short of fields or ending in a field that is not a
// number: a row cut by a full disk or a killed writer. (A whole last row without its newline, as
// some programs write, is kept.)
bool CsvLogReader::row_is_cut(std::size_t n_fields) const {
  if (!unterminated_) return false;
  if (n_fields < columns_.size()) return true;
  if (n_fields > columns_.size()) return false;
  const std::string& f = fields_[n_fields - 1];
  double v;
  return !f.empty() && !is_nan_text(f) && !parse_double(f, v);
}

bool CsvLogReader::next() {
  for (;;) {
    if (!read_line(text_)) return false;
    std::size_t lead = 0;
    std::string t = trim(text_, &lead);
    if (t.empty() || t[0] == '#') continue;  // blank lines and late comments carry no sample
    break;
  }
  std::size_t start = 0;
  std::size_t n = 0;
  for (;;) {
    std::size_t comma = text_.find(',', start);
    if (n >= columns_.size())
      throw LogError(name_, line_, static_cast<int>(start) + 1, "more fields than the header's " +
                                                                std::to_string(columns_.size()) +
                                                                " columns");
    std::size_t lead = 0;
    fields_[n] = trim(text_.substr(start, comma == std::string::npos ? std::string::npos
                                                                       : comma - start),
                      &lead);
    field_start_col_[n] = static_cast<int>(start + lead) + 1;
    ++n;
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (row_is_cut(n)) {
    last_row_cut_ = true;
    std::fprintf(stderr,
                 "%s:%d: warning: the last row is cut short (%zu of %zu fields, no newline at the end of the file: "
                 "a full disk or a killed writer?); it is ignored, the rows before it are read\n",
                 name_.c_str(), line_, n, columns_.size());
    return false;
  }
  if (n != columns_.size())
    throw LogError(name_, line_, static_cast<int>(text_.size()) + 1,
                   std::to_string(n) + " fields where the header has " +
                       std::to_string(columns_.size()) + " columns");
  for (std::size_t i = 0; i < n; ++i) {
    const std::string& f = fields_[i];
    if (f.empty() || is_nan_text(f)) {
      values_[i] = kNotMeasured;
    } else if (!parse_double(f, values_[i])) {
      values_[i] = kNotMeasured;
      // Unknown columns may hold text; only known ones are checked by the typed readers,
      // but t_s is always numeric.
      if (static_cast<int>(i) == t_col_) fail_at_field(static_cast<int>(i), "bad number " + quote(f));
    }
  }
  const double t = values_[static_cast<std::size_t>(t_col_)];
  if (!measured(t)) fail_at_field(t_col_, "empty t_s");
  if (const std::string e = check_bound("t_s", t, limits::kLogTime); !e.empty()) fail_at_field(t_col_, e);
  if (!(t > last_t_s_))
    fail_at_field(t_col_, "t_s " + quote(fields_[static_cast<std::size_t>(t_col_)]) +
                              " does not increase (previous " + std::to_string(last_t_s_) + ")");
  // Samples closer than a microsecond are no clock's (a log 3e-297 s long fitted a model).
  if (t - last_t_s_ < limits::kMinSampleStepS)
    fail_at_field(t_col_, "t_s " + quote(fields_[static_cast<std::size_t>(t_col_)]) + " is less than 1 us after the previous row");
  last_t_s_ = t;
  return true;
}

// ---------------------------------------------------------------- CsvLogWriter
CsvLogWriter::CsvLogWriter(std::ostream& out,
                           const std::vector<std::pair<std::string, std::string>>& metadata,
                           const std::vector<std::string>& columns)
    : out_(&out), columns_(columns) {
  for (const auto& [k, v] : metadata) {
    if (k.empty() || k.find_first_of(" \t:\n\r") != std::string::npos ||
        v.find_first_of("\n\r") != std::string::npos)
      throw std::invalid_argument("bad log metadata key/value " + quote(k));
    *out_ << "# " << k << ": " << v << '\n';
  }
  for (std::size_t i = 0; i < columns_.size(); ++i) {
    if (columns_[i].empty() || columns_[i].find_first_of(", \t\n\r#") != std::string::npos)
      throw std::invalid_argument("bad log column name " + quote(columns_[i]));
    if (columns_[i] == "t_s") t_col_ = static_cast<int>(i);
    *out_ << (i ? "," : "") << columns_[i];
  }
  *out_ << '\n';
  row_.reserve(columns_.size() * 12);
}

void CsvLogWriter::write_row(const double* values, std::size_t count) {
  if (count != columns_.size())
    throw std::invalid_argument("log row has " + std::to_string(count) + " values for " +
                                std::to_string(columns_.size()) + " columns");
  if (t_col_ >= 0) {
    const double t = values[t_col_];
    if (!measured(t) || !(t > last_t_s_))
      throw std::invalid_argument("log t_s must increase strictly");
    last_t_s_ = t;
  }
  row_.clear();
  for (std::size_t i = 0; i < count; ++i) {
    if (i) row_.push_back(',');
    append_number(row_, values[i]);
  }
  row_.push_back('\n');
  out_->write(row_.data(), static_cast<std::streamsize>(row_.size()));
}

// ---------------------------------------------------------------- robot log
namespace {

// Standard robot-log columns with how each maps onto RobotSample.
enum class Field { t, omega, cmd, current, voltage, pwm, status, seq_ack, x, y, psi, imu_psi, imu_r,
                   xd, yd, psid, loop_dt, imu_ax, imu_ay };
struct RobotColumn {
  std::string name;
  Field field;
  int screw;
};

const std::vector<RobotColumn>& robot_columns() {
  static const std::vector<RobotColumn> cols = [] {
    std::vector<RobotColumn> c;
    c.push_back({"t_s", Field::t, 0});
    const std::pair<const char*, Field> per_screw[] = {
        {"omega_rpm_", Field::omega}, {"cmd_rpm_", Field::cmd},   {"current_a_", Field::current},
        {"voltage_v_", Field::voltage}, {"pwm_", Field::pwm},     {"status_", Field::status},
        {"seq_ack_", Field::seq_ack}};
    // omega first: it is required; pose next as the other required group.
    for (int i = 0; i < 4; ++i) c.push_back({std::string("omega_rpm_") + char('0' + i), Field::omega, i});
    c.push_back({"x_m", Field::x, 0});
    c.push_back({"y_m", Field::y, 0});
    c.push_back({"psi_rad", Field::psi, 0});
    c.push_back({"imu_psi_rad", Field::imu_psi, 0});
    c.push_back({"imu_r_radps", Field::imu_r, 0});
    c.push_back({"xd_m", Field::xd, 0});
    c.push_back({"yd_m", Field::yd, 0});
    c.push_back({"psid_rad", Field::psid, 0});
    for (std::size_t k = 1; k < std::size(per_screw); ++k)
      for (int i = 0; i < 4; ++i)
        c.push_back({std::string(per_screw[k].first) + char('0' + i), per_screw[k].second, i});
    c.push_back({"loop_dt_s", Field::loop_dt, 0});
    // Last, so that a log of before them keeps its column order; optional as every column
    // but the required ones (a log without them reads as not measured).
    c.push_back({"imu_ax_mps2", Field::imu_ax, 0});
    c.push_back({"imu_ay_mps2", Field::imu_ay, 0});
    return c;
  }();
  return cols;
}

// S is RobotSample or const RobotSample: one mapping for reading and writing.
template <class S>
auto robot_field(S& s, const RobotColumn& c) -> decltype(&s.t_s) {
  const auto i = static_cast<std::size_t>(c.screw);
  switch (c.field) {
    case Field::t: return &s.t_s;
    case Field::omega: return &s.omega_rpm[i];
    case Field::cmd: return &s.cmd_rpm[i];
    case Field::current: return &s.current_a[i];
    case Field::voltage: return &s.voltage_v[i];
    case Field::pwm: return &s.pwm[i];
    case Field::x: return &s.x_m;
    case Field::y: return &s.y_m;
    case Field::psi: return &s.psi_rad;
    case Field::imu_psi: return &s.imu_psi_rad;
    case Field::imu_r: return &s.imu_r_radps;
    case Field::xd: return &s.xd_m;
    case Field::yd: return &s.yd_m;
    case Field::psid: return &s.psid_rad;
    case Field::loop_dt: return &s.loop_dt_s;
    case Field::imu_ax: return &s.imu_ax_mps2;
    case Field::imu_ay: return &s.imu_ay_mps2;
    case Field::status:
    case Field::seq_ack: return nullptr;  // integers, handled apart
  }
  return nullptr;
}

const std::vector<std::string> kRobotRequired = {"t_s", "omega_rpm_0", "omega_rpm_1", "omega_rpm_2",
                                                 "omega_rpm_3", "x_m", "y_m", "psi_rad"};

// Reads a numeric field that the typed reader knows: text that is not a number is an error, and
// so is a value outside its physical bounds (input_limits.hpp; null: any finite number).
double known_value(const CsvLogReader& csv, int col, const InputBound* bound = nullptr) {
  double v = csv.value(col);
  if (!measured(v) && !csv.field_text(col).empty() && !is_nan_text(csv.field_text(col)))
    csv.fail_at_field(col, "bad number " + quote(csv.field_text(col)));
  if (bound && measured(v)) {
    const std::string e = check_bound(csv.columns()[static_cast<std::size_t>(col)].c_str(), v, *bound);
    if (!e.empty()) csv.fail_at_field(col, e);
  }
  return v;
}

// The bounds of a robot-log column's quantity (null: none beyond a finite number).
const InputBound* robot_bound(Field f) {
  switch (f) {
    case Field::omega:
    case Field::cmd: return &limits::kScrewSpeed;
    case Field::x:
    case Field::y:
    case Field::xd:
    case Field::yd: return &limits::kPosition;
    case Field::psi:
    case Field::imu_psi:
    case Field::psid: return &limits::kHeading;
    case Field::imu_r: return &limits::kYawRate;
    case Field::imu_ax:
    case Field::imu_ay: return &limits::kAcceleration;
    default: return nullptr;
  }
}

std::optional<std::int64_t> known_integer(const CsvLogReader& csv, int col) {
  double v = known_value(csv, col);
  if (!measured(v)) return std::nullopt;
  if (v != std::floor(v) || std::fabs(v) > 9.0e15)
    csv.fail_at_field(col, "not an integer " + quote(csv.field_text(col)));
  return static_cast<std::int64_t>(v);
}

}  // namespace

const std::vector<std::string>& robot_log_columns() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& c : robot_columns()) n.push_back(c.name);
    return n;
  }();
  return names;
}

RobotLogReader::RobotLogReader(const std::string& path) : csv_(path) { bind(); }
RobotLogReader::RobotLogReader(std::istream& in, std::string name) : csv_(in, std::move(name)) {
  bind();
}

void RobotLogReader::bind() {
  csv_.check_format(kRobotLogFormat);
  csv_.require_columns(kRobotRequired);
  const auto& cols = robot_columns();
  index_.resize(cols.size());
  for (std::size_t k = 0; k < cols.size(); ++k) index_[k] = csv_.column_index(cols[k].name);
  for (int i = 0; i < static_cast<int>(csv_.columns().size()); ++i)
    if (std::find(index_.begin(), index_.end(), i) == index_.end()) extra_.push_back(i);
}

bool RobotLogReader::next(RobotSample& s) {
  if (!csv_.next()) return false;
  s = RobotSample{};
  const auto& cols = robot_columns();
  for (std::size_t k = 0; k < cols.size(); ++k) {
    const int col = index_[k];
    if (col < 0) continue;
    if (double* f = robot_field(s, cols[k])) {
      *f = known_value(csv_, col, robot_bound(cols[k].field));
    } else {
      auto& arr = cols[k].field == Field::status ? s.status : s.seq_ack;
      arr[static_cast<std::size_t>(cols[k].screw)] = known_integer(csv_, col);
    }
  }
  return true;
}

RobotLogWriter::RobotLogWriter(std::ostream& out,
                               std::vector<std::pair<std::string, std::string>> metadata,
                               const std::vector<std::string>& extra_columns)
    : csv_(out,
           [&] {
             auto it = std::find_if(metadata.begin(), metadata.end(),
                                    [](const auto& kv) { return kv.first == "format"; });
             if (it == metadata.end()) metadata.insert(metadata.begin(), {"format", kRobotLogFormat});
             return metadata;
           }(),
           [&] {
             auto c = robot_log_columns();
             c.insert(c.end(), extra_columns.begin(), extra_columns.end());
             return c;
           }()),
      n_extra_(extra_columns.size()) {
  row_.resize(csv_.columns().size());
}

void robot_log_row(const RobotSample& sample, const std::vector<double>& extra, std::vector<double>& row) {
  const auto& cols = robot_columns();
  row.resize(cols.size() + extra.size());
  for (std::size_t k = 0; k < cols.size(); ++k) {
    if (const double* f = robot_field(sample, cols[k])) {
      row[k] = *f;
    } else {
      const auto& arr = cols[k].field == Field::status ? sample.status : sample.seq_ack;
      const auto& v = arr[static_cast<std::size_t>(cols[k].screw)];
      row[k] = v ? static_cast<double>(*v) : kNotMeasured;
    }
  }
  std::copy(extra.begin(), extra.end(), row.begin() + static_cast<std::ptrdiff_t>(cols.size()));
}

void RobotLogWriter::write(const RobotSample& sample, const std::vector<double>& extra) {
  if (extra.size() != n_extra_) throw std::invalid_argument("wrong number of extra log values");
  robot_log_row(sample, extra, row_);
  csv_.write_row(row_.data(), row_.size());
}

// ---------------------------------------------------------------- gantry log
namespace {
const std::vector<std::string> kGantryColumns = {"t_s", "omega_rpm_0", "omega_rpm_1", "force_n",
                                                 "position_m"};
}

GantryLogReader::GantryLogReader(const std::string& path) : csv_(path) { bind(); }
GantryLogReader::GantryLogReader(std::istream& in, std::string name) : csv_(in, std::move(name)) {
  bind();
}

void GantryLogReader::bind() {
  csv_.check_format(kGantryLogFormat);
  for (const auto& m : csv_.metadata()) {
    if (m.key == "mass_kg") meta_.mass_kg = csv_.metadata_number(m, limits::kGantryMass);
    if (m.key == "axis" && m.value != "longitudinal" && m.value != "lateral")
      throw LogError(csv_.name(), m.line, 1, "metadata 'axis' must be longitudinal or lateral, not " + quote(m.value));
    if (m.key == "axis") meta_.axis = m.value;
    if (m.key == "terrain") meta_.terrain = m.value;
  }
  csv_.require_columns(kGantryColumns);
  for (std::size_t k = 0; k < kGantryColumns.size(); ++k) index_[k] = csv_.column_index(kGantryColumns[k]);
}

const std::string& GantryLogReader::axis() const {
  if (meta_.axis.empty())
    throw LogError(csv_.name(), csv_.header_line(), 1,
                   "no '# axis:' metadata before the header (longitudinal or lateral)");
  return meta_.axis;
}

bool GantryLogReader::next(GantrySample& s) {
  if (!csv_.next()) return false;
  s.t_s = csv_.t_s();
  s.omega_rpm[0] = known_value(csv_, index_[1], &limits::kScrewSpeed);
  s.omega_rpm[1] = known_value(csv_, index_[2], &limits::kScrewSpeed);
  s.force_n = known_value(csv_, index_[3], &limits::kForce);
  s.position_m = known_value(csv_, index_[4], &limits::kPosition);
  return true;
}

GantryLogWriter::GantryLogWriter(std::ostream& out,
                                 std::vector<std::pair<std::string, std::string>> metadata)
    : csv_(out,
           [&] {
             auto it = std::find_if(metadata.begin(), metadata.end(),
                                    [](const auto& kv) { return kv.first == "format"; });
             if (it == metadata.end()) metadata.insert(metadata.begin(), {"format", kGantryLogFormat});
             return metadata;
           }(),
           kGantryColumns) {}

void GantryLogWriter::write(const GantrySample& s) {
  const double row[5] = {s.t_s, s.omega_rpm[0], s.omega_rpm[1], s.force_n, s.position_m};
  csv_.write_row(row, 5);
}

}  // namespace auger
