// `auger merge ROBOT_LOG CAMERA_LOG [--out LOG] [--json]`: aligns a camera's pose log with a
// robot log (merge_align.cpp) and writes the robot log with the camera pose filled in.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <string>
#include <vector>

#include "auger/args.hpp"
#include "auger/log.hpp"
#include "auger/measured.hpp"
#include "cli_text.hpp"
#include "commands.hpp"
#include "merge.hpp"
#include "workbench.hpp"

namespace auger::wb {
namespace {

const CommandLine kCli{
    "auger merge",
    "ROBOT_LOG CAMERA_LOG [--out LOG] [--max-shift S] [--json]",
    "Aligns CAMERA_LOG (t_s, x_m, y_m, psi_rad and its own t0_unix_s) with ROBOT_LOG: offset from\n"
    "the logs' t0_unix_s, refined by cross-correlating the robot's imu_r_radps with the camera's\n"
    "heading rate. Prints the offset (t_robot = t_camera + offset) and its quality.\n",
    {{"--out", "LOG", "write the robot log with x_m, y_m, psi_rad from the camera, interpolated to\n"
      "the robot's samples"},
     {"--max-shift", "S", "refine the offset within +-S s (default 30 s)"},
     {"--json", "", "one JSON object on stdout"}},
    "Exit 1 if the correlation is poor (nothing written); 2: bad usage.\n"};

int merge_usage(std::FILE* f, int code) {
  kCli.print_usage(f);
  return code;
}

double parse_number(const char* text, const char* what) {
  double v = 0;
  if (!decimal_number(text, v)) throw std::invalid_argument(std::string(what) + " '" + text + "' is not a number");
  return v;
}

}  // namespace

int run_merge(int argc, char** argv) {
  bool json = false;
  std::string out_path;
  MergeOptions options;
  std::vector<std::string> files;
  try {
    Args args;
    if (const int rc = kCli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
    json = args.has("--json");
    out_path = args.get("--out");
    if (args.has("--max-shift")) {
      options.max_shift_s = parse_number(args.get("--max-shift").c_str(), "--max-shift");
      if (!(options.max_shift_s > 0 && options.max_shift_s <= kMaxShiftS))
        throw std::invalid_argument("--max-shift must be in (0, " + std::to_string(int(kMaxShiftS)) + "] s");
    }
    files = args.positional;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger merge: %s\n", e.what());
    return 2;
  }
  if (files.size() != 2) return merge_usage(stderr, 2);

  std::vector<RobotSample> rows;
  std::vector<std::vector<double>> extra_rows;
  std::vector<std::string> extra_names;
  std::vector<std::pair<std::string, std::string>> metadata;
  PoseTrack camera;
  double t0_robot = 0, t0_camera = 0;
  bool robot_has_t0 = false, camera_has_t0 = false;
  try {
    RobotLogReader reader(files[0]);
    const CsvLogReader& csv = reader.csv();
    for (const auto& m : csv.metadata()) {
      if (m.key == "t0_unix_s") {
        t0_robot = parse_t0_unix_s(files[0], m);
        robot_has_t0 = true;
      }
      if (m.key != "format" && m.key != "merged_camera_log" && m.key != "camera_offset_s")
        metadata.push_back({m.key, m.value});
    }
    for (int c : reader.extra_columns()) extra_names.push_back(csv.columns()[static_cast<std::size_t>(c)]);
    RobotSample s;
    while (reader.next(s)) {
      rows.push_back(s);
      std::vector<double> extra;
      for (int c : reader.extra_columns()) extra.push_back(csv.value(c));
      extra_rows.push_back(std::move(extra));
    }
    if (rows.empty()) throw LogError(files[0], csv.header_line() + 1, 1, "no samples after the header");
    camera = read_pose_track(files[1], &t0_camera, &camera_has_t0);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger merge: %s\n", e.what());
    return 2;
  }

  const bool t0_used = robot_has_t0 && camera_has_t0;
  // t_robot = t_camera + (t0_camera - t0_robot): both t_s count from their own t0.
  const double coarse = t0_used ? t0_camera - t0_robot : 0.0;
  std::vector<double> t_s, imu_r;
  for (const auto& r : rows) t_s.push_back(r.t_s), imu_r.push_back(r.imu_r_radps);
  Alignment al;
  try {
    al = align_camera(t_s, imu_r, camera, coarse, t0_used, options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger merge: %s\n", e.what());
    return 2;
  }

  std::size_t filled = 0, replaced = 0;
  const bool write = !out_path.empty() && al.quality != "poor";
  if (write) {
    std::ofstream out(out_path);
    if (!out) {
      std::fprintf(stderr, "auger merge: cannot write '%s'\n", out_path.c_str());
      return 2;
    }
    metadata.push_back({"merged_camera_log", files[1]});
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6f", al.offset_s);
    metadata.push_back({"camera_offset_s", buf});
    RobotLogWriter writer(out, metadata, extra_names);
    for (std::size_t k = 0; k < rows.size(); ++k) {
      RobotSample s = rows[k];
      replaced += measured(s.x_m) || measured(s.y_m) || measured(s.psi_rad);
      s.x_m = s.y_m = s.psi_rad = kNotMeasured;
      filled += camera_pose_at(camera, s.t_s, al.offset_s, options.max_gap_s, s.x_m, s.y_m, s.psi_rad);
      writer.write(s, extra_rows[k]);
    }
    out.flush();
    if (!out) {
      out.close();
      std::remove(out_path.c_str());  // no half-written log left behind
      std::fprintf(stderr, "auger merge: writing '%s' failed\n", out_path.c_str());
      return 2;
    }
  }

  std::string next;
  if (al.quality == "poor")
    next = "check that the two logs are of the same run (and --max-shift covers their clocks' difference)";
  else if (write)
    next = "auger compare " + typed(out_path) + " (the model against the merged log)";
  else
    next = "auger merge " + typed(files[0]) + " " + typed(files[1]) + " --out merged.csv (write the merged log)";
  if (json) {
    Json j;
    j.begin_object().str("command", "merge").str("robot_log", files[0]).str("camera_log", files[1]);
    j.boolean("t0_used", al.t0_used).num("coarse_offset_s", al.coarse_offset_s);
    j.boolean("refined", al.refined).num("offset_s", al.offset_s);
    j.num("refinement_s", al.offset_s - al.coarse_offset_s);
    j.num("correlation", al.correlation).num("second_peak", al.second_peak);
    j.num("overlap_s", al.overlap_s).num("grid_dt_s", al.grid_dt_s);
    j.str("quality", al.quality).str("note", al.note);
    if (write) {
      j.str("out", out_path).num("rows", static_cast<double>(rows.size()));
      j.num("rows_with_camera_pose", static_cast<double>(filled)).num("rows_pose_replaced", static_cast<double>(replaced));
    } else {
      j.num("out", kNaN);  // null: nothing written
    }
    j.str("next", next);
    j.end_object();
    std::printf("%s\n", j.text().c_str());
  } else {
    std::printf("auger merge: t_robot = t_camera %c %.4f s\n", al.offset_s < 0 ? '-' : '+', std::fabs(al.offset_s));
    char coarse_text[48];
    std::snprintf(coarse_text, sizeof coarse_text, "%.4f s", al.coarse_offset_s);
    std::printf("  from t0_unix_s: %s\n",
                t0_used ? coarse_text
                        : "not available (a log has no t0_unix_s), 0 assumed");
    if (al.refined)
      std::printf("  refined by %+.4f s: IMU yaw rate vs camera heading rate, correlation r = %.3f over %.1f s, "
                  "best r more than 1 s away %.3f\n",
                  al.offset_s - al.coarse_offset_s, al.correlation, al.overlap_s, al.second_peak);
    std::printf("  quality: %s%s%s\n", al.quality.c_str(), al.note.empty() ? "" : ": ", al.note.c_str());
    if (write)
      std::printf("  wrote %s: %zu of %zu rows with the camera pose%s\n", out_path.c_str(), filled, rows.size(),
                  replaced ? (", " + std::to_string(replaced) + " rows' own pose replaced").c_str() : "");
    std::printf("next: %s\n", next.c_str());
  }
  if (al.quality == "poor") {
    std::fprintf(stderr, "auger merge: alignment is poor (%s); %s\n", al.note.c_str(),
                 out_path.empty() ? "nothing to write" : "nothing written");
    return 1;
  }
  return 0;
}

}  // namespace auger::wb
