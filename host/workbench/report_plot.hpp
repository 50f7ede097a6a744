// Plots for `auger report` that are not time series (the path, the candidates, the effect's
// curves), drawn by gnuplot (Debian gnuplot-nox, `set terminal svg`) run without a shell: the
// data and the script go to a private temporary directory, gnuplot writes an SVG, and the SVG
// text comes back ready to be inlined in the HTML (its XML prologue removed, its ids made unique).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace auger::wb {

// A string as a gnuplot single-quoted literal ('' for a quote inside; newlines become spaces),
// for every label, title and file name put into a script.
std::string gp_quote(const std::string& s);

// gnuplot is missing or failed; the message says which and what to install.
class PlotError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Gnuplot {
 public:
  // The executable: $AUGER_GNUPLOT if set, else `gnuplot` on PATH. Throws PlotError if it cannot
  // be run, before any work is done.
  Gnuplot();
  ~Gnuplot();  // removes the temporary directory
  Gnuplot(const Gnuplot&) = delete;
  Gnuplot& operator=(const Gnuplot&) = delete;

  const std::string& executable() const { return exe_; }
  std::string version() const { return version_; }
  int plots() const { return count_; }  // SVGs drawn so far

  // Writes equal-length columns as a whitespace table (NaN as "NaN", which the scripts declare
  // missing); returns the file's path, quoted for a gnuplot script.
  std::string data(const std::string& name, const std::vector<std::vector<double>>& columns);
  // Runs `script` (after a common preamble: SVG terminal of width x height, output file, NaN
  // missing) and returns the SVG element. Throws PlotError with gnuplot's messages.
  std::string svg(const std::string& name, const std::string& script, int width = 900, int height = 420);

 private:
  std::string exe_, dir_, version_;
  int count_ = 0;
};

// Keeps at most max_points of a series for plotting: per bin, the sample of largest |value|
// (so error peaks survive) for `peaks`, else every k-th sample.
std::vector<std::size_t> decimate(const std::vector<double>& t, const std::vector<double>& v, std::size_t max_points,
                                  bool peaks);

}  // namespace auger::wb
