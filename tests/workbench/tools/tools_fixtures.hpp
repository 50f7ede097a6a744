// Helpers of the workbench tools' tests (identify, merge, report, bad input): run the real
// `auger` binary and capture what it prints, read its JSON with Python's json module (a real
// parser, so "one JSON object" is checked, not assumed), and generate logs with known truth.
#pragma once

#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>

namespace tools_test {

struct RunResult {
  int code = -1;
  std::string out, err;
};

inline std::string read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
  if (!f) throw std::runtime_error("cannot write " + path);
}

// A fresh directory for one test's files.
inline std::string temp_dir(const std::string& tag) {
  std::string templ = "/tmp/auger-wbtools-" + tag + "-XXXXXX";
  if (!mkdtemp(templ.data())) throw std::runtime_error("mkdtemp failed");
  return templ;
}

inline std::string shell_quote(const std::string& s);

// The directory of one test case, removed with everything in it at the end of the case
// (kept when AUGER_KEEP_TEST_FILES is set, to look at what a failing case wrote).
struct TempDir {
  explicit TempDir(const std::string& tag) : path(temp_dir(tag)) {}
  ~TempDir() {
    const char* keep = std::getenv("AUGER_KEEP_TEST_FILES");
    if (keep && *keep) return;
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string path;
};

inline std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs `auger ARGS` (args already quoted as needed) with stdout and stderr captured apart.
inline RunResult run_auger(const std::string& dir, const std::string& args, const std::string& env = "") {
  const std::string out = dir + "/.stdout", err = dir + "/.stderr";
  const std::string cmd = env + " " + shell_quote(AUGER_PATH) + " " + args + " >" + shell_quote(out) +
                          " 2>" + shell_quote(err);
  const int status = std::system(cmd.c_str());
  RunResult r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}

// Evaluates a Python expression over the parsed JSON `d` of text; throws if the text is not
// exactly one JSON object (trailing text included).
inline std::string json_eval(const std::string& dir, const std::string& text, const std::string& expr) {
  const std::string in = dir + "/.json", out = dir + "/.json_out";
  write_text(in, text);
  const std::string cmd =
      "python3 -c 'import json,sys\nd=json.loads(open(sys.argv[1]).read())\n"
      "assert isinstance(d, dict)\nprint(eval(sys.argv[2]))' " +
      shell_quote(in) + " " + shell_quote(expr) + " >" + shell_quote(out) + " 2>&1";
  const int status = std::system(cmd.c_str());
  std::string r = read_text(out);
  while (!r.empty() && (r.back() == '\n' || r.back() == '\r')) r.pop_back();
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) throw std::runtime_error("json_eval(" + expr + "): " + r);
  return r;
}

// A valid robot log, 60 s at 100 Hz: the screws turn at slowly changing speeds, the camera pose
// every 5th row with a gap of NaN rows, the IMU rate every row.
inline std::string good_robot_log() {
  std::ostringstream os;
  os << "# format: auger-robot-log v1\n# terrain: sand\n"
     << "t_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad,imu_r_radps\n";
  double x = 0;
  for (int k = 0; k < 6000; ++k) {
    const double t = 0.01 * k, w = 10 * std::sin(0.2 * t);
    x += 0.004 * w * 0.01;
    os << t << ',' << -w << ',' << -w << ',' << w << ',' << w << ',';
    if (k % 5 == 0 && !(k > 2000 && k < 2300)) os << x << ",0,0";
    else if (k % 5 == 0) os << "nan,NaN,";
    else os << ",,";
    os << ',' << (k % 50 == 7 ? std::string() : "0") << '\n';
  }
  return os.str();
}

inline std::string camera_log() {
  std::ostringstream os;
  os << "# format: auger-robot-log v1\nt_s,x_m,y_m,psi_rad\n";
  for (int k = 0; k < 1200; ++k) os << 0.05 * k << ',' << 0.01 * k << ",0," << 0.1 * std::sin(0.05 * k) << '\n';
  return os.str();
}

inline double json_number(const std::string& dir, const std::string& text, const std::string& expr) {
  return std::stod(json_eval(dir, text, expr));
}

}  // namespace tools_test
