// Robot-log rows (docs/log-format.md) as MCAP channels that Foxglove and PlotJuggler show
// without configuration (docs/formats.md "MCAP"): JSON messages with JSON schemas, the pose as
// foxglove.PoseInFrame and foxglove.FrameTransform, every other column in a flat message whose
// fields are the log's column names. Used by `auger export` and by augerd (MCAP beside its
// CSV log); the tests read the files back with the independent Python `mcap` reader.
#pragma once

#include <cstdint>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "auger/log.hpp"
#include "auger/mcap.hpp"

namespace auger {

class RobotLogMcapWriter {
 public:
  // metadata: the log's `# key: value` lines (kept as the MCAP metadata record "auger-log");
  // columns: the log's columns in row order, t_s among them. Times in the file are
  // t0_unix_s + t_s when the metadata has t0_unix_s, else t_s from the Unix epoch.
  RobotLogMcapWriter(std::ostream& out, const std::vector<std::pair<std::string, std::string>>& metadata,
                     const std::vector<std::string>& columns, std::size_t chunk_bytes = 1u << 20);
  // The columns of a RobotLogWriter: robot_log_columns(), then these.
  struct RobotColumnsAnd {
    std::vector<std::string> extra;
  };
  // The same file from RobotLogWriter's arguments (for augerd, which would write its samples to
  // both); write() takes what RobotLogWriter::write takes.
  RobotLogMcapWriter(std::ostream& out, const std::vector<std::pair<std::string, std::string>>& metadata,
                     const RobotColumnsAnd& columns, std::size_t chunk_bytes = 1u << 20);
  void write(const RobotSample& sample, const std::vector<double>& extra = {});
  // One row, values in the order of columns (NaN = not measured: the field is left out, and a
  // message none of whose fields is measured is not written).
  void write_row(const double* values, std::size_t count);
  // The model's prediction at t_s (the workbench's; NaN where it has none): /model/pose_2d,
  // /model/pose and the frame base_link_model on /tf.
  void write_prediction(double t_s, double x_m, double y_m, double psi_rad, double imu_psi_rad);
  void flush() { mcap_.flush(); }
  std::string tail() const { return mcap_.tail(); }  // McapWriter::tail
  void finish() { mcap_.finish(); }
  std::uint64_t message_count() const { return mcap_.message_count(); }

  // A flat channel and the columns that feed it.
  struct Group {
    std::uint16_t channel = 0;
    std::vector<int> cols;
  };

 private:
  std::uint64_t time_ns(double t_s) const;
  void write_pose(std::uint16_t pose_channel, std::uint16_t tf_channel, const char* child, std::uint64_t ns,
                  double x, double y, double psi);

  McapWriter mcap_;
  std::vector<std::string> columns_;
  int t_col_ = -1;
  std::int64_t t0_ns_ = 0;
  std::vector<Group> groups_;
  std::uint16_t pose_schema_ = 0, pose_ch_ = 0, tf_ch_ = 0, ref_pose_ch_ = 0, model_flat_ch_ = 0, model_pose_ch_ = 0;
  int x_col_ = -1, y_col_ = -1, psi_col_ = -1, xd_col_ = -1, yd_col_ = -1, psid_col_ = -1;
  std::string msg_;
  std::vector<double> row_;
};

}  // namespace auger
