// Every workbench subcommand on a corpus of hostile inputs (issue 13): each run must exit 2 with
// one short message naming the problem on stderr, never crash (no uncaught exception, no abort),
// never print half a JSON object, never exit 0 on nonsense, and leave no output file or
// directory behind. The subcommands are a table: a new one is one line in kCommands; a new kind
// of hostile input is one entry in corpus().
#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "gantry_gen.hpp"
#include "tools_fixtures.hpp"

namespace {

// {LOG} the hostile log (or the good one when the entry is a hostile model), {MODEL} "--model
// FILE" for an entry with a hostile model (else nothing), {GOOD} a valid robot log, {OUT} a
// directory for outputs, which must stay empty.
struct Command {
  const char* id;    // the name in Hostile::may_run
  const char* name;  // the subcommand
  const char* args;
};
const std::vector<Command> kCommands = {
    {"compare", "compare", "{LOG} {MODEL} --json"},
    {"diagnose", "diagnose", "{LOG} {MODEL} --threads 1 --json"},
    {"fit", "fit", "{LOG} {MODEL} --add coulomb_friction --out {OUT}/fit.toml --json"},
    {"report", "report", "{LOG} {MODEL} --out {OUT}/report --json"},
    {"identify", "identify", "{LOG} --json"},
    {"merge-robot", "merge", "{LOG} {GOOD} --out {OUT}/merged.csv --json"},
    {"merge-camera", "merge", "{GOOD} {LOG} --out {OUT}/merged.csv --json"},
    {"effects", "effects", "{LOG}"},
    {"explain", "explain", "{LOG} {MODEL} --threads 1 --out {OUT}/explain.toml --json"},
};

struct Hostile {
  std::string name;
  std::string log;    // the log's text ("" with path set: that path as is)
  std::string path;   // a path to use instead of a written file (a directory, a device, ...)
  std::string model;  // a hostile model file's text: the log is then the good one
  std::set<std::string> may_run;  // commands for which this input is data, not nonsense (exit 0 or 1)
};

std::string robot_log(int rows, double dt_s, const std::string& omega0 = "", const std::string& extra_meta = "") {
  std::ostringstream os;
  os.precision(17);
  os << "# format: auger-robot-log v1\n# terrain: sand\n" << extra_meta
     << "t_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad,imu_r_radps\n";
  for (int k = 0; k < rows; ++k) {
    const double w = 10 * std::sin(0.05 * k);
    os << k * dt_s << ',' << (omega0.empty() ? std::to_string(-w) : omega0) << ',' << -w << ',' << w << ',' << w
       << ',' << 0.001 * k << ",0," << 0.2 * std::sin(0.1 * k) << ',' << 0.02 * std::cos(0.1 * k) << '\n';
  }
  return os.str();
}

std::vector<Hostile> corpus(const std::string& good_model) {
  std::vector<Hostile> c;
  c.push_back({"empty file", "", "", "", {}});
  {
    std::string junk;
    for (int i = 0; i < 4096; ++i) junk += char((i * 7919 + 13) % 256);
    c.push_back({"binary garbage with NULs", junk, "", "", {}});
  }
  c.push_back({"header only", "# format: auger-robot-log v1\nt_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad\n",
               "", "", {}});
  {
    std::string l = robot_log(300, 0.01);
    l.insert(l.find("\n0.01") + 1, std::string(10u << 20, '9') + "x");  // a 10 MB field
    c.push_back({"10 MB field", l, "", "", {}});
  }
  {
    std::string h = "# format: auger-robot-log v1\nt_s";
    for (int i = 0; i < 100000; ++i) h += ",c" + std::to_string(i);
    c.push_back({"100 000 columns, none required", h + "\n0" + std::string(100000, ',') + "\n", "", "", {}});
  }
  c.push_back({"time steps of 1e6 s", robot_log(300, 1e6), "", "", {}});
  c.push_back({"a log 3e-297 s long", robot_log(50, 6e-299), "", "", {}});
  // merge reads only the pose of a camera log: its screw speeds are no input there.
  c.push_back({"1e308 rpm", robot_log(300, 0.01, "1e308"), "", "", {"merge-camera"}});
  c.push_back({"t_s of 1e300", "# format: auger-robot-log v1\nt_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad\n1e300,0,0,0,0,0,0,0\n",
               "", "", {}});
  c.push_back({"t0_unix_s of 1e300", robot_log(3000, 0.01, "", "# t0_unix_s: 1e300\n"), "", "", {}});
  {
    std::string l = robot_log(300, 0.01);
    l.replace(l.find("\n0.5,") + 1, 0, std::string("0.49\0,1,1,1,1,0,0,0,0\n", 22));
    c.push_back({"a NUL byte in a row", l, "", "", {}});
  }
  {
    std::ostringstream os;
    os << "# format: auger-robot-log v1\nt_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad\n";
    for (int k = 0; k < 3000; ++k) os << 0.01 * k << ",1,1,1,1,,,\n";
    c.push_back({"no pose at all", os.str(), "", "", {"merge-robot"}});  // the camera gives it
  }
  {
    std::ostringstream os;  // 60 s, a pose every 5 s: too sparse to fit anything
    os << "# format: auger-robot-log v1\n# terrain: sand\nt_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad\n";
    for (int k = 0; k < 6000; ++k) {
      os << 0.01 * k << ",-5,-5,5,5,";
      if (k % 500 == 0) os << 0.0002 * k << ",0,0\n";
      else os << ",,\n";
    }
    c.push_back({"12 poses in 60 s", os.str(), "", "", {"merge-robot", "merge-camera"}});
  }
  c.push_back({"5 s of log", robot_log(500, 0.01), "", "", {"compare", "merge-robot", "merge-camera"}});
  c.push_back({"a directory", "", "/tmp", "", {}});
  c.push_back({"a character device", "", "/dev/zero", "", {}});
  c.push_back({"a missing file", "", "/nonexistent/dir/log.csv", "", {}});
  {
    tools_test::GantryTruth tr;
    tr.reps = 1;
    std::string g = tools_test::gantry_log_text(tools_test::make_gantry(tr, 1));
    std::string huge = g;
    huge.replace(huge.find("# mass_kg: "), huge.find('\n', huge.find("# mass_kg: ")) - huge.find("# mass_kg: "),
                 "# mass_kg: 1e308");
    c.push_back({"gantry mass_kg 1e308", huge, "", "", {}});
    std::string side = g;
    side.replace(side.find("# axis: "), side.find('\n', side.find("# axis: ")) - side.find("# axis: "),
                 "# axis: sideways");
    c.push_back({"gantry axis sideways", side, "", "", {}});
  }
  // Hostile models with the good log.
  {
    std::string m = good_model;
    for (std::size_t p = m.find("D_x = "); p != std::string::npos; p = m.find("D_x = ", p + 1))
      m.replace(p, m.find('\n', p) - p, "D_x = 0");
    c.push_back({"a model with D_x = 0", "", "", m, {}});
  }
  {
    std::string m = good_model;  // frozen_grass only: the log's terrain (sand) is missing
    const auto sand = m.find("[terrain.sand]");
    const auto next = m.find("[terrain.", sand + 1);
    m.erase(sand, next - sand);
    c.push_back({"a model without the log's terrain", "", "", m, {}});
  }
  c.push_back({"a model that is not TOML", "", "", std::string("[terrain.sand\nsigma_long = \0", 30), {}});
  return c;
}

std::string expand(std::string t, const std::string& key, const std::string& value) {
  for (std::size_t p = t.find(key); p != std::string::npos; p = t.find(key, p + value.size()))
    t.replace(p, key.size(), value);
  return t;
}

bool exists(const std::string& p) {
  struct stat st {};
  return stat(p.c_str(), &st) == 0;
}

}  // namespace

TEST_CASE("every workbench subcommand refuses hostile input with exit 2 and leaves nothing behind") {
  const tools_test::TempDir tmp("hostile");
  const std::string dir = tmp.path, out = dir + "/out";
  tools_test::write_text(dir + "/good.csv", tools_test::good_robot_log());
  const std::string good_model = tools_test::read_text(AUGER_SOURCE_DIR "/models/robot.toml");
  REQUIRE(!good_model.empty());
  REQUIRE(mkdir(out.c_str(), 0755) == 0);
  int k = 0, runs = 0;
  for (const Hostile& h : corpus(good_model)) {
    std::string log = h.path, model_opt;
    if (log.empty()) {
      log = dir + "/h" + std::to_string(k++) + ".csv";
      tools_test::write_text(log, h.model.empty() ? h.log : tools_test::good_robot_log());
    }
    if (!h.model.empty()) {
      const std::string m = dir + "/m" + std::to_string(k++) + ".toml";
      tools_test::write_text(m, h.model);
      model_opt = "--model " + tools_test::shell_quote(m);
    }
    for (const Command& c : kCommands) {
      const std::string args_t = c.args;
      if (!h.model.empty() && args_t.find("{MODEL}") == std::string::npos) continue;  // the log is good
      std::string args = expand(expand(expand(expand(args_t, "{LOG}", tools_test::shell_quote(log)), "{MODEL}", model_opt),
                                       "{GOOD}", tools_test::shell_quote(dir + "/good.csv")),
                                "{OUT}", out);
      // Hostile input is refused quickly; a hang is a failure too.
      const auto r = tools_test::run_auger(dir, std::string(c.name) + " " + args, "timeout 60");
      ++runs;
      INFO("[" << h.name << "] auger " << c.name << " " << args.substr(0, 300) << "\nexit " << r.code
               << "\nstderr: " << r.err.substr(0, 2000) << "\nstdout: " << r.out.substr(0, 300));
      if (h.may_run.count(c.id)) {
        CHECK((r.code == 0 || r.code == 1 || r.code == 2));
      } else {
        CHECK(r.code == 2);
        CHECK(r.out.find('{') == std::string::npos);  // no half JSON object
      }
      CHECK(r.err.find("terminate called") == std::string::npos);
      CHECK((r.code == 0 || r.code == 1 || r.err.find("auger " + std::string(c.name) + ": ") != std::string::npos));
      CHECK(r.err.size() < 4000);  // one message, long fields cut
      if (r.code != 0) {
        for (const char* made : {"/fit.toml", "/report", "/merged.csv", "/explain.toml"}) {
          INFO(made);
          CHECK_FALSE(exists(out + made));
        }
      }
      for (const char* made : {"/fit.toml", "/merged.csv", "/explain.toml"}) std::remove((out + made).c_str());
      std::error_code ec;
      std::filesystem::remove_all(out + "/report", ec);
    }
  }
  WARN(runs << " runs of the workbench's subcommands on hostile input");
}
