// The gnuplot driver (gnuplot.hpp): run without a shell (process.hpp: an argument vector),
// every string in a script quoted by gp_quote.
#include "gnuplot.hpp"
#include "process.hpp"

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

namespace auger::io {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

void replace_all(std::string& s, const std::string& from, const std::string& to) {
  for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
}

}  // namespace

std::string gp_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) {
    if (c == '\'') q += "''";            // the one escape inside gnuplot's single quotes
    else if (c == '\n' || c == '\r') q += ' ';  // a script line ends at a newline
    else q += c;
  }
  return q + "'";
}

Gnuplot::Gnuplot() {
  const char* env = std::getenv("AUGER_GNUPLOT");
  exe_ = env && *env ? env : "gnuplot";
  std::string templ = (std::filesystem::temp_directory_path() / "auger-plot-XXXXXX").string();
  if (!mkdtemp(templ.data())) throw PlotError("cannot create a temporary directory for the plots");
  dir_ = templ;
  const std::string out = dir_ + "/version.txt";
  const int status = run_program(exe_, {"--version"}, out, out + ".err");
  version_ = slurp(out);
  while (!version_.empty() && (version_.back() == '\n' || version_.back() == '\r')) version_.pop_back();
  if (!program_succeeded(status) || version_.rfind("gnuplot", 0) != 0) {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
    throw PlotError("gnuplot not found or not working ('" + exe_ +
                    " --version' failed): the plots are drawn with gnuplot; install the Debian package "
                    "gnuplot-nox (scripts/install-deps.sh does)");
  }
}

Gnuplot::~Gnuplot() {
  const char* keep = std::getenv("AUGER_REPORT_KEEP_PLOTS");  // debugging: keep scripts and data
  if (keep && *keep) {
    std::fprintf(stderr, "auger: plot scripts and data kept in %s\n", dir_.c_str());
    return;
  }
  std::error_code ec;
  if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
}

std::string Gnuplot::data(const std::string& name, const std::vector<std::vector<double>>& columns) {
  const std::string path = dir_ + "/" + name + ".dat";
  std::ofstream f(path);
  const std::size_t n = columns.empty() ? 0 : columns.front().size();
  char buf[32];
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      const double v = columns[c][i];
      if (std::isfinite(v)) std::snprintf(buf, sizeof buf, "%.9g", v);
      else std::snprintf(buf, sizeof buf, "NaN");
      f << (c ? " " : "") << buf;
    }
    f << '\n';
  }
  if (!f) throw PlotError("cannot write plot data " + path);
  return gp_quote(path);
}

std::string Gnuplot::run_script(const std::string& name, const std::string& script) {
  const std::string id = "p" + std::to_string(++count_) + "_" + name;
  const std::string gp_path = dir_ + "/" + id + ".gp", out_path = dir_ + "/" + id + ".out",
                    err_path = dir_ + "/" + id + ".err";
  {
    std::ofstream gp(gp_path);
    gp << script << "\n";
    if (!gp) throw PlotError("cannot write " + gp_path);
  }
  const int status = run_program(exe_, {gp_path}, out_path, err_path);
  if (!program_succeeded(status)) throw PlotError("gnuplot failed on plot '" + name + "': " + slurp(err_path));
  return slurp(out_path);
}

std::string Gnuplot::svg(const std::string& name, const std::string& script, int width, int height) {
  const std::string id = "p" + std::to_string(count_ + 1) + "_" + name;
  const std::string svg_path = dir_ + "/" + id + ".svg";
  std::ostringstream gp;
  gp << "set terminal svg size " << width << "," << height
     << " noenhanced font 'sans,11' background rgb 'white'\n"
     << "set output " << gp_quote(svg_path) << "\n"
     << "set datafile missing NaN\nset grid\nset key outside top center horizontal\n"
     << script << "\nset output";
  run_script(name, gp.str());
  std::string svg = slurp(svg_path);
  if (svg.find("</svg>") == std::string::npos) throw PlotError("gnuplot wrote no SVG for plot '" + name + "'");
  // Inline: no XML prologue; ids unique across the report's plots.
  const std::size_t start = svg.find("<svg");
  svg = svg.substr(start, svg.rfind("</svg>") + 6 - start);
  replace_all(svg, "id='gp", "id='" + id + "_gp");
  replace_all(svg, "'#gp", "'#" + id + "_gp");
  replace_all(svg, "id=\"gnuplot_", "id=\"" + id + "_gnuplot_");
  for (const char* filter : {"textbox", "greybox"}) {
    replace_all(svg, std::string("id='") + filter + "'", "id='" + id + "_" + filter + "'");
    replace_all(svg, std::string("url(#") + filter + ")", "url(#" + id + "_" + filter + ")");
  }
  replace_all(svg, "id=\"gpPt", "id=\"" + id + "_gpPt");
  replace_all(svg, "\"#gpPt", "\"#" + id + "_gpPt");
  return svg;
}

}  // namespace auger::io
