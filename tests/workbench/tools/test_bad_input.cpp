// Bad input for every workbench command, at the command line: a corpus of broken logs made
// here (missing required column, non-increasing time, text in a number, empty file), each
// expected to exit 2 with "file:line:column:" on stderr and nothing but (at most) an empty
// stdout; a last line cut short (a full disk), which is read up to it with a warning; and
// sparse pose rows with NaN gaps, which are normal data. test_hostile_input.cpp has the rest.
#include <catch2/catch.hpp>

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "auger/measured.hpp"
#include "gantry_gen.hpp"
#include "tools_fixtures.hpp"

namespace {

struct BadFile {
  std::string name;     // what is wrong
  std::string text;     // the file
  int line = 0, column = 0;
  std::string keyword;  // a word the message must contain
};

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream is(text);
  for (std::string l; std::getline(is, l);) lines.push_back(l);
  return lines;
}

std::string join_lines(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

// 1-based column where field `field` (0-based) of a CSV line starts.
int field_column(const std::string& line, int field) {
  std::size_t pos = 0;
  for (int f = 0; f < field; ++f) pos = line.find(',', pos) + 1;
  return static_cast<int>(pos) + 1;
}

std::string replace_field(const std::string& line, int field, const std::string& text) {
  const std::size_t b = static_cast<std::size_t>(field_column(line, field) - 1);
  const std::size_t e = line.find(',', b);
  return line.substr(0, b) + text + (e == std::string::npos ? "" : line.substr(e));
}

// The broken variants of a valid log: header at header_line (1-based), a data line to spoil,
// the column of a field that must be numeric and the name of one required column.
std::vector<BadFile> corpus(const std::string& good, int header_line, int text_field,
                            const std::string& required_column) {
  std::vector<BadFile> c;
  const auto lines = split_lines(good);
  const int hi = header_line - 1;
  const int bad_row = header_line + 40;  // 1-based line of the spoiled row
  {  // the required column renamed in the header
    auto l = lines;
    const std::string& h = l[static_cast<std::size_t>(hi)];
    l[static_cast<std::size_t>(hi)] = h.substr(0, h.find(required_column)) + "renamed" +
                                      h.substr(h.find(required_column) + required_column.size());
    c.push_back({"missing column", join_lines(l), header_line, 1, required_column});
  }
  {  // t_s of a row equal to the previous one
    auto l = lines;
    const std::string prev_t = l[static_cast<std::size_t>(bad_row - 2)].substr(0, l[static_cast<std::size_t>(bad_row - 2)].find(','));
    auto& row = l[static_cast<std::size_t>(bad_row - 1)];
    row = replace_field(row, 0, prev_t);
    c.push_back({"non-increasing time", join_lines(l), bad_row, 1, "does not increase"});
  }
  {  // text in a numeric field
    auto l = lines;
    auto& row = l[static_cast<std::size_t>(bad_row - 1)];
    row = replace_field(row, text_field, "twelve");
    c.push_back({"text in a number", join_lines(l), bad_row, field_column(row, text_field), "twelve"});
  }
  c.push_back({"empty file", "", 1, 1, "no header"});
  return c;
}

void expect_bad(const std::string& dir, const std::string& command, const BadFile& bad, const std::string& path,
                const std::string& args) {
  const auto r = tools_test::run_auger(dir, command + " " + args);
  INFO("auger " << command << " " << args << "\n(" << bad.name << ")\nstderr: " << r.err << "\nstdout: " << r.out);
  CHECK(r.code == 2);
  const std::string where = path + ":" + std::to_string(bad.line) + ":" + std::to_string(bad.column) + ":";
  CHECK_THAT(r.err, Catch::Contains(where) && Catch::Contains(bad.keyword));
  CHECK(r.out.find('{') == std::string::npos);  // no half JSON object on stdout
}

}  // namespace

TEST_CASE("robot-log commands refuse broken logs naming file, line and column (exit 2)") {
  const tools_test::TempDir tmp("bad");
  const std::string dir = tmp.path;
  const std::string good = tools_test::good_robot_log();
  tools_test::write_text(dir + "/camera.csv", tools_test::camera_log());
  tools_test::write_text(dir + "/good.csv", good);
  int k = 0;
  for (const BadFile& bad : corpus(good, 3, 2, "omega_rpm_2")) {
    const std::string path = dir + "/bad" + std::to_string(k++) + ".csv";
    tools_test::write_text(path, bad.text);
    for (const std::string cmd : {"compare", "diagnose", "fit", "report", "merge"}) {
      std::string args = path + " --json";
      if (std::string(cmd) == "fit") args = path + " --add coulomb_friction --json";
      if (std::string(cmd) == "report") args = path + " --out " + dir + "/report";
      if (std::string(cmd) == "merge") args = path + " " + dir + "/camera.csv --json";
      expect_bad(dir, cmd, bad, path, args);
    }
  }
  // merge's camera log: its own required columns (t_s, x_m, y_m, psi_rad).
  for (const BadFile& bad : corpus(tools_test::camera_log(), 2, 1, "psi_rad")) {
    const std::string path = dir + "/badcam" + std::to_string(k++) + ".csv";
    tools_test::write_text(path, bad.text);
    expect_bad(dir, "merge", bad, path, dir + "/good.csv " + path + " --json");
  }
}

TEST_CASE("a log whose screw-speed columns are empty in every row is refused, not run on 0 rpm (exit 2)") {
  // Issue 28 point 8: compare exited 0 on such a log (the gaps' fill, 0 rpm, as the screws).
  const tools_test::TempDir tmp("noscrews");
  const std::string dir = tmp.path;
  auto lines = split_lines(tools_test::good_robot_log());
  const std::string header = lines[2];  // the header is line 3
  auto field_of = [&](const std::string& name) {
    int f = 0;
    for (std::size_t p = 0; p < header.find(name); ++p) f += header[p] == ',';
    return f;
  };
  for (const std::vector<int>& blank : {std::vector<int>{0, 1, 2, 3}, std::vector<int>{2}}) {
    auto l = lines;
    for (std::size_t r = 3; r < l.size(); ++r)
      for (int i : blank) l[r] = replace_field(l[r], field_of("omega_rpm_" + std::to_string(i)), "");
    const std::string path = dir + "/blank" + std::to_string(blank.size()) + ".csv";
    tools_test::write_text(path, join_lines(l));
    std::string names;
    for (int i : blank) names += (names.empty() ? "omega_rpm_" : ", omega_rpm_") + std::to_string(i);
    for (const char* cmd : {"compare", "diagnose"}) {
      const auto r = tools_test::run_auger(dir, std::string(cmd) + " " + path);
      INFO(cmd << " " << path << "\nstderr: " << r.err);
      CHECK(r.code == 2);
      CHECK_THAT(r.err, Catch::Contains(path + ":1:1: no row has a screw speed in " + names + ":"));
    }
  }
}

TEST_CASE("identify refuses broken gantry logs and a log without its axis (exit 2)") {
  const tools_test::TempDir tmp("badg");
  const std::string dir = tmp.path;
  tools_test::GantryTruth tr;
  tr.reps = 1;
  const std::string good = tools_test::gantry_log_text(tools_test::make_gantry(tr, 1));
  int k = 0;
  auto cases = corpus(good, 5, 4, "force_n");
  {
    auto l = split_lines(good);
    l.erase(l.begin() + 1);  // "# axis: ..."
    cases.push_back({"no axis metadata", join_lines(l), 4, 1, "axis"});
  }
  for (const BadFile& bad : cases) {
    const std::string path = dir + "/bad" + std::to_string(k++) + ".csv";
    tools_test::write_text(path, bad.text);
    expect_bad(dir, "identify", bad, path, path + " --json");
  }
}

namespace {
// The last line cut in the middle (a full disk, a killed logger): the rows before it are data.
std::string cut_last_line(const std::string& good, int* line) {
  auto l = split_lines(good);
  auto& last = l.back();
  last = last.substr(0, static_cast<std::size_t>(field_column(last, 2)));
  *line = static_cast<int>(l.size());
  std::string text = join_lines(l);
  text.pop_back();  // no newline at the end either
  return text;
}
}  // namespace

TEST_CASE("a last line cut short is read up to it, with a warning naming the line") {
  const tools_test::TempDir tmp("cut");
  const std::string dir = tmp.path;
  int line = 0;
  tools_test::write_text(dir + "/cut.csv", cut_last_line(tools_test::good_robot_log(), &line));
  auto r = tools_test::run_auger(dir, "compare " + dir + "/cut.csv --json");
  INFO(r.err);
  CHECK(r.code == 0);
  CHECK_THAT(r.err, Catch::Contains(dir + "/cut.csv:" + std::to_string(line) + ": warning: the last row is cut short"));
  CHECK(tools_test::json_number(dir, r.out, "d['samples']") == 5999);
  tools_test::GantryTruth tr;
  tr.reps = 1;
  tools_test::write_text(dir + "/gcut.csv",
                         cut_last_line(tools_test::gantry_log_text(tools_test::make_gantry(tr, 1)), &line));
  r = tools_test::run_auger(dir, "identify " + dir + "/gcut.csv --json");
  INFO(r.err);
  CHECK(r.code == 0);
  CHECK_THAT(r.err, Catch::Contains("gcut.csv:" + std::to_string(line) + ": warning: the last row is cut short"));
}

TEST_CASE("sparse pose rows and NaN gaps are data, not errors") {
  const tools_test::TempDir tmp("sparse");
  const std::string dir = tmp.path;
  tools_test::write_text(dir + "/good.csv", tools_test::good_robot_log());
  for (const std::string cmd : {"compare", "diagnose"}) {
    const auto r = tools_test::run_auger(dir, cmd + " " + dir + "/good.csv --json");
    INFO(cmd << ": " << r.err);
    CHECK(r.code != 2);
    CHECK_NOTHROW(tools_test::json_eval(dir, r.out, "1"));  // exactly one JSON object
  }
  // Gantry: force and position missing on some rows.
  tools_test::GantryTruth tr;
  tr.reps = 2;
  auto g = tools_test::make_gantry(tr, 5);
  for (std::size_t i = 0; i < g.t_s.size(); i += 7) g.force_n[i] = auger::kNotMeasured;
  for (std::size_t i = 0; i < g.t_s.size(); i += 3) g.position_m[i] = auger::kNotMeasured;
  std::string text = tools_test::gantry_log_text(g);
  tools_test::write_text(dir + "/gantry.csv", text);
  const auto r = tools_test::run_auger(dir, "identify " + dir + "/gantry.csv --json");
  INFO(r.err);
  CHECK(r.code == 0);
  CHECK(tools_test::json_number(dir, r.out, "d['groups'][0]['sigma_long']['value']") == Approx(0.812).epsilon(0.05));
}
