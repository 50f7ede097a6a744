// The one gnuplot driver (Debian gnuplot-nox), for `auger report`'s plots and `auger step --plot`:
// gnuplot runs without a shell (posix_spawnp, an argument vector), the data and the script go
// to a private temporary directory, and every string put into a script (labels, titles, file
// names, the user's output path) is a gnuplot single-quoted literal (gp_quote): a path with
// quotes or ';' in it is plotted to, never executed.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace auger::io {

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
  int plots() const { return count_; }  // scripts run so far

  // Writes equal-length columns as a whitespace table (NaN as "NaN", which the scripts declare
  // missing); returns the file's path, quoted for a gnuplot script.
  std::string data(const std::string& name, const std::vector<std::vector<double>>& columns);
  // A file in the private directory (removed with it), e.g. data written by the caller.
  std::string path(const std::string& file) const { return dir_ + "/" + file; }
  // Runs a whole script (its own terminal and output) and returns what gnuplot printed on
  // stdout (a `dumb` terminal's plot). Throws PlotError with gnuplot's messages.
  std::string run_script(const std::string& name, const std::string& script);
  // Runs `script` (after a common preamble: SVG terminal of width x height, output file, NaN
  // missing) and returns the SVG element, ready to be inlined in HTML (no XML prologue, ids made
  // unique). Throws PlotError with gnuplot's messages.
  std::string svg(const std::string& name, const std::string& script, int width = 900, int height = 420);

 private:
  std::string exe_, dir_, version_;
  int count_ = 0;
};

}  // namespace auger::io
