// `auger export LOG --mcap OUT.mcap [--model FILE] [--json]`: a robot log as MCAP (core's
// RobotLogMcapWriter), with the workbench's prediction beside the measurement on request.
// The file is written under a temporary name and renamed when complete: never a partial output.
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "auger/args.hpp"
#include "auger/log.hpp"
#include "auger/log_mcap.hpp"
#include "interop.hpp"
#include "output.hpp"
#include "workbench.hpp"

namespace auger::interop {

namespace {

const CommandLine kCli{
    "auger export",
    "LOG --mcap OUT.mcap [--model FILE] [--json]",
    "The robot log as MCAP for Foxglove and PlotJuggler (docs/formats.md): the pose as\n"
    "foxglove.PoseInFrame on /pose and a frame on /tf, the columns in flat JSON messages on\n"
    "/screws, /pose_2d, /imu, /reference, /status, /other.\n",
    {{"--mcap", "OUT.mcap", "the MCAP file to write"},
     {"--model", "FILE", "a model file, or \"default\" for the shipped one: also the model's prediction\n"
      "from the measured screw speeds (as `auger compare` runs it: re-started from\n"
      "the measured pose every 25 s) on /model/pose_2d, /model/pose and the frame\n"
      "base_link_model"},
     {"--json", "", "one JSON object on stdout"}},
    "Exit 0: written; 2: bad usage or input (nothing written, an existing OUT.mcap kept).\n"};

}  // namespace

int run_export(int argc, char** argv) {
  Args a;
  if (const int rc = kCli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
  if (a.positional.size() != 1 || !a.has("--mcap")) return kCli.print_usage(stderr), 2;
  const std::string log_path = a.positional[0];
  const std::string out_path = a.get("--mcap");
  std::string tmp_path = out_path + ".part-XXXXXX";
  int fd = -1;
  try {
    // The typed reader checks every known column (numbers, integers, required columns, t_s);
    // its generic reader gives every column's value, other programs' columns too.
    RobotLogReader reader(log_path);
    const CsvLogReader& log = reader.csv();
    std::vector<std::pair<std::string, std::string>> meta;
    for (const auto& m : log.metadata()) meta.emplace_back(m.key, m.value);

    // The prediction first (it reads the log on its own), so a bad model fails before writing.
    wb::Dataset data;
    wb::Prediction pred;
    std::string model_source;
    if (a.has("--model")) {
      data = wb::load_dataset(log_path);
      const std::string m = a.get("--model");
      wb::ModelChoice mc = wb::choose_model(data, m == "default" ? "" : m);
      model_source = mc.source;
      wb::simulate(mc.model, data, wb::sim_options_for(mc.model), pred);
    }

    fd = mkstemp(tmp_path.data());
    if (fd < 0) {
      std::fprintf(stderr, "auger export: cannot write beside %s: %s\n", out_path.c_str(), std::strerror(errno));
      return 2;
    }
    const mode_t mask = umask(0);  // mkstemp makes 0600; an output file gets the usual 0666 & ~umask
    umask(mask);
    fchmod(fd, 0666 & ~mask);
    close(fd);
    std::ofstream out(tmp_path, std::ios::binary | std::ios::trunc);
    RobotLogMcapWriter w(out, meta, log.columns());
    std::size_t rows = 0;
    double t_first = 0, t_last = 0;
    RobotSample sample;
    while (reader.next(sample)) {
      std::vector<double> v(log.columns().size());
      for (std::size_t i = 0; i < v.size(); ++i) v[i] = log.value(static_cast<int>(i));
      w.write_row(v.data(), v.size());
      if (rows == 0) t_first = log.t_s();
      t_last = log.t_s();
      if (!pred.pred.empty() && rows < pred.pred.size() && data.t_s[rows] == log.t_s()) {
        const auto& p = pred.pred[rows];
        w.write_prediction(log.t_s(), p[wb::kX], p[wb::kY], p[wb::kPsi], p[wb::kImuPsi]);
      }
      ++rows;
    }
    w.finish();
    out.close();
    if (!out) throw std::runtime_error("writing " + out_path + " failed (disk full?)");
    if (std::rename(tmp_path.c_str(), out_path.c_str()) != 0)
      throw std::runtime_error("cannot rename " + tmp_path + " to " + out_path + ": " + std::strerror(errno));
    const char* next = "open it in Foxglove (Open local file) or PlotJuggler (Load Data); docs/formats.md";
    if (a.has("--json")) {
      wb::Json j;
      j.begin_object().str("command", "export").str("log", log_path).str("out", out_path);
      j.num("rows", static_cast<double>(rows)).num("duration_s", t_last - t_first);
      j.num("messages", static_cast<double>(w.message_count()));
      if (model_source.empty())
        j.num("model", wb::kNaN);  // null: no prediction
      else
        j.str("model", model_source);
      j.str("next", next).end_object();
      std::printf("%s\n", j.text().c_str());
      return 0;
    }
    std::printf("auger export: %s -> %s: %zu rows, %.2f s, %llu messages%s%s\n", log_path.c_str(), out_path.c_str(),
                rows, t_last - t_first, static_cast<unsigned long long>(w.message_count()),
                model_source.empty() ? "" : "; prediction of ", model_source.c_str());
    std::printf("next: %s\n", next);
    return 0;
  } catch (const std::exception& e) {
    if (fd >= 0) std::remove(tmp_path.c_str());
    std::fprintf(stderr, "auger export: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::interop
