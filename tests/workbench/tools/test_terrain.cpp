// Terrain (issue 26 point 3, docs/workbench.md "Terrain"): a log without `# terrain:` is analysed
// with a stated assumption in every output (text, JSON `warnings`, report); when the paper's
// parameters for another table terrain explain it clearly better, the outputs say so and the next
// command names it; `--terrain NAME|auto`.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <sstream>
#include <string>

#include "tools_fixtures.hpp"

namespace {

// auger-sim-log's frozen-grass log of 60 s, with and without its terrain line.
void frozen_grass_logs(const std::string& dir, std::string& with, std::string& without) {
  with = dir + "/fg.csv";
  without = dir + "/fg_no_terrain.csv";
  REQUIRE(std::system((tools_test::shell_quote(AUGER_SIM_LOG_PATH) + " --out " + tools_test::shell_quote(with) +
                       " --terrain frozen_grass --seconds 60 --seed 3 2>/dev/null")
                          .c_str()) == 0);
  std::istringstream in(tools_test::read_text(with));
  std::string kept;
  int dropped = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("# terrain:", 0) == 0) {
      ++dropped;
      continue;
    }
    kept += line + "\n";
  }
  REQUIRE(dropped == 1);
  tools_test::write_text(without, kept);
}

}  // namespace

TEST_CASE("a frozen-grass log without its terrain line: the assumption stated, frozen grass named, --terrain auto") {
  const tools_test::TempDir tmp("terrain");
  const std::string dir = tmp.path;
  std::string with, log;
  frozen_grass_logs(dir, with, log);

  // compare: text on stdout and stderr.
  const auto t = tools_test::run_auger(dir, "compare " + log);
  INFO(t.out << t.err);
  REQUIRE(t.code == 0);
  CHECK_THAT(t.out, Catch::Contains("terrain: sand (assumed: the log names none"));
  CHECK_THAT(t.err, Catch::Contains("warning: the log names no terrain") && Catch::Contains("an assumption"));
  CHECK_THAT(t.err, Catch::Contains("the paper's parameters for terrain 'frozen_grass' explain this log clearly better"));
  CHECK_THAT(t.out, Catch::Contains("next: auger compare " + log + " --terrain frozen_grass"));

  // compare --json: the assumption and the better terrain in `warnings`, the fits.
  const auto j = tools_test::run_auger(dir, "compare " + log + " --json");
  REQUIRE(j.code == 0);
  CHECK(tools_test::json_eval(dir, j.out, "d['terrain'], d['terrain_from'], d['terrain_better']") ==
        "('sand', 'assumed', 'frozen_grass')");
  CHECK(tools_test::json_eval(dir, j.out, "any('names no terrain' in w for w in d['warnings'])") == "True");
  CHECK(tools_test::json_eval(dir, j.out, "any(\"'frozen_grass' explain\" in w for w in d['warnings'])") == "True");
  // The fits are the headline errors: sand's is compare's own segments figure.
  CHECK(tools_test::json_number(dir, j.out, "d['terrain_fits']['frozen_grass'] / d['terrain_fits']['sand']") < 0.8);
  CHECK(tools_test::json_number(
            dir, j.out, "abs(d['terrain_fits']['sand'] - (sum(v*v for v in d['segments']['ratio_to_noise'].values()) / "
                        "len(d['segments']['ratio_to_noise'])) ** 0.5)") < 1e-6);

  // --terrain auto picks frozen grass and says so; the table terrain's own model is then at the noise.
  const auto a = tools_test::run_auger(dir, "compare " + log + " --terrain auto --json");
  REQUIRE(a.code == 0);
  CHECK(tools_test::json_eval(dir, a.out, "d['terrain'], d['terrain_from'], d['terrain_better']") ==
        "('frozen_grass', 'auto', '')");
  CHECK(tools_test::json_eval(dir, a.out, "any('--terrain auto' in w for w in d['warnings'])") == "True");
  CHECK(tools_test::json_number(dir, a.out, "max(d['segments']['ratio_to_noise'].values())") < 1.3);
  CHECK_THAT(a.err, Catch::Contains("--terrain auto: analysed as terrain 'frozen_grass'"));

  // The log with its terrain line: no warning at all.
  const auto w = tools_test::run_auger(dir, "compare " + with + " --json");
  REQUIRE(w.code == 0);
  CHECK(tools_test::json_eval(dir, w.out, "d['warnings'], d['terrain_from'], d['terrain_better']") == "([], 'log', '')");

  // A terrain the tables lack: exit 2 naming it and the ones they have.
  const auto bad = tools_test::run_auger(dir, "compare " + log + " --terrain mud");
  CHECK(bad.code == 2);
  CHECK_THAT(bad.err, Catch::Contains("'mud'") && Catch::Contains("sand, frozen_grass"));

  // diagnose: the verdict followed by the better terrain, and the next command is that terrain's.
  const auto d = tools_test::run_auger(dir, "diagnose " + log + " --json");
  INFO(d.err);
  REQUIRE(d.code == 0);
  CHECK(tools_test::json_eval(dir, d.out, "d['terrain_better']") == "frozen_grass");
  CHECK_THAT(tools_test::json_eval(dir, d.out, "d['next']"),
             Catch::StartsWith("auger diagnose " + log + " --terrain frozen_grass"));
  const auto dt = tools_test::run_auger(dir, "diagnose " + log);
  CHECK_THAT(dt.out, Catch::Contains("but the paper's parameters for terrain 'frozen_grass' explain this log clearly "
                                     "better than those of 'sand'"));

  // The report: the assumption on the page and in its JSON.
  const auto r = tools_test::run_auger(dir, "report " + log + " --out " + dir + "/rep --no-diagnose --json");
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(tools_test::json_eval(dir, r.out, "d['terrain_from'], any('names no terrain' in w for w in d['warnings'])") ==
        "('assumed', True)");
  const std::string page = tools_test::read_text(dir + "/rep/index.html");
  CHECK_THAT(page, Catch::Contains("<p class=warn>Warning: the log names no terrain"));
  CHECK_THAT(page, Catch::Contains("<td class=l id=terrain>terrain: sand (assumed"));
}
