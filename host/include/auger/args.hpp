// The one argument parser of the host's programs (the auger subcommands, augerd, the tools):
// positional arguments, `--flag`, `--key VALUE` or `--key=VALUE`, `-h` for `--help`; an
// unknown option or a missing value is a usage error naming it (printed as "PROGRAM: ...").
// Anything not starting with "--" is positional, so a negative number ("-5") is one.
// CommandLine (below) holds a program's options as one table, from which its --help is printed.
#pragma once

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <vector>

#include "auger/version.hpp"

namespace auger {

// The one number parser of the command lines and option values: the whole text a finite decimal
// number ("1.5", "-2e-3"); hexadecimal ("0x1"), "inf", "nan", blanks and trailing text are not.
inline bool decimal_number(const std::string& text, double& out) {
  if (text.empty() || text.find_first_not_of("0123456789+-.eE") != std::string::npos) return false;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (*end != '\0' || errno == ERANGE || !std::isfinite(v)) return false;
  out = v;
  return true;
}

struct Args {
  std::vector<std::string> positional;
  std::vector<std::pair<std::string, std::string>> options;  // --key value ("" for flags)
  bool has(const std::string& k) const {
    for (const auto& o : options)
      if (o.first == k) return true;
    return false;
  }
  std::string get(const std::string& k, const std::string& dflt = "") const {
    for (const auto& o : options)
      if (o.first == k) return o.second;
    return dflt;
  }
  // The option's value as a finite number (the whole text), dflt if absent; false (and
  // printed) if it is not one.
  bool number(const char* program, const std::string& k, double dflt, double& out) const {
    out = dflt;
    if (!has(k)) return true;
    return to_number(program, k, get(k), out);
  }
  // The option's value as a whole number in lo..hi (the whole text, decimal), dflt if absent;
  // false (and printed) if it is not one.
  bool whole(const char* program, const std::string& k, long dflt, long lo, long hi, long& out) const {
    out = dflt;
    if (!has(k)) return true;
    const std::string text = get(k);
    double v = 0;
    if (!decimal_number(text, v) || v != std::floor(v) || v < static_cast<double>(lo) || v > static_cast<double>(hi) ||
        text.find_first_of(".eE") != std::string::npos) {
      std::fprintf(stderr, "%s: %s: '%s' is not a whole number from %ld to %ld\n", program, k.c_str(), text.c_str(), lo, hi);
      return false;
    }
    out = static_cast<long>(v);
    return true;
  }
  // As number(), and inside (lo, hi) (open bounds).
  bool number_in(const char* program, const std::string& k, double dflt, double lo, double hi, double& out) const {
    if (!number(program, k, dflt, out)) return false;
    if (has(k) && !(out > lo && out < hi)) {
      std::fprintf(stderr, "%s: %s: '%s' is not between %g and %g\n", program, k.c_str(), get(k).c_str(), lo, hi);
      return false;
    }
    return true;
  }
  // The option's value as comma-separated finite numbers (each field the whole text between
  // commas, as number()), exactly `count` of them when count > 0, at least one otherwise; out
  // untouched if absent; false (and printed) if it is not such a list.
  bool numbers(const char* program, const std::string& k, std::size_t count, std::vector<double>& out) const {
    if (!has(k)) return true;
    const std::string text = get(k);
    std::vector<double> v;
    for (std::size_t at = 0;;) {
      const std::size_t comma = text.find(',', at);
      double x = 0;
      if (!decimal_number(text.substr(at, comma == std::string::npos ? std::string::npos : comma - at), x)) {
        std::fprintf(stderr, "%s: %s: '%s' is not %s finite numbers a,b,...\n", program, k.c_str(), text.c_str(),
                     count > 0 ? std::to_string(count).c_str() : "comma-separated");
        return false;
      }
      v.push_back(x);
      if (comma == std::string::npos) break;
      at = comma + 1;
    }
    if (count > 0 && v.size() != count) {
      std::fprintf(stderr, "%s: %s: '%s' is not %zu finite numbers a,b,...\n", program, k.c_str(), text.c_str(), count);
      return false;
    }
    out = std::move(v);
    return true;
  }
  static bool to_number(const char* program, const std::string& what, const std::string& text, double& out) {
    if (!decimal_number(text, out)) {
      std::fprintf(stderr, "%s: %s: '%s' is not a finite number\n", program, what.c_str(), text.c_str());
      return false;
    }
    return true;
  }
};

// flags: options without a value; valued: options with one. Returns false (and prints) on error.
// program: the name in messages; "" for "auger ARGV[0]" (a subcommand's argv[0] is its name).
inline bool parse_args(int argc, char** argv, const std::set<std::string>& flags,
                       const std::set<std::string>& valued, Args& out, const std::string& program = "") {
  const std::string who = program.empty() ? std::string("auger ") + argv[0] : program;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "-h" && flags.count("--help")) a = "--help";
    if (a.size() > 2 && a.compare(0, 2, "--") == 0) {
      std::string value;
      const auto eq = a.find('=');
      if (eq != std::string::npos) {
        value = a.substr(eq + 1);
        a = a.substr(0, eq);
      }
      if (flags.count(a)) {
        out.options.push_back({a, ""});
      } else if (valued.count(a)) {
        if (eq == std::string::npos) {
          if (i + 1 >= argc) {
            std::fprintf(stderr, "%s: option %s needs a value\n", who.c_str(), a.c_str());
            return false;
          }
          value = argv[++i];
        }
        out.options.push_back({a, value});
      } else {
        std::fprintf(stderr, "%s: unknown option '%s'\n", who.c_str(), a.c_str());
        return false;
      }
    } else {
      out.positional.push_back(a);
    }
  }
  return true;
}

// One option of a program's table: its name, its value's name ("": a flag), its help ('\n' between
// lines; the usage aligns them).
struct OptionDoc {
  std::string name, value, help;
};

// A program's command line as one table: the usage text (`--help`) and what parse accepts both
// come from it. --help (and -h) and --version are added to every table.
struct CommandLine {
  std::string program;             // "auger step", "augerd"
  std::string synopsis;            // the arguments, e.g. "MODULE RPM [OPTIONS]"
  std::string about;               // what it does; lines end with '\n'
  std::vector<OptionDoc> options;
  std::string more;                // after the options (exit codes, notes); lines end with '\n'

  void print_usage(std::FILE* f) const {
    std::fprintf(f, "usage: %s %s\n%s", program.c_str(), synopsis.c_str(), about.c_str());
    std::vector<OptionDoc> all = options;
    all.push_back({"--help", "", "this text"});
    all.push_back({"--version", "", "the version"});
    std::size_t width = 0;
    std::vector<std::string> heads;
    for (const auto& o : all) {
      heads.push_back(o.name + (o.value.empty() ? "" : " " + o.value));
      width = std::max(width, heads.back().size());
    }
    std::fprintf(f, "options:\n");
    for (std::size_t i = 0; i < all.size(); ++i) {
      // A help text of several lines: each further line starts under the first one's text.
      std::string help;
      for (const char c : all[i].help) help += c == '\n' ? "\n" + std::string(width + 4, ' ') : std::string(1, c);
      std::fprintf(f, "  %-*s  %s\n", int(width), heads[i].c_str(), help.c_str());
    }
    std::fprintf(f, "%s", more.c_str());
  }
  // False on a usage error: the message ("PROGRAM: ...") and the usage go to stderr.
  bool parse(int argc, char** argv, Args& out) const {
    std::set<std::string> flags = {"--help", "--version"}, valued;
    for (const auto& o : options) (o.value.empty() ? flags : valued).insert(o.name);
    if (parse_args(argc, argv, flags, valued, out, program)) return true;
    print_usage(stderr);
    return false;
  }
  // parse, then --help and --version answered here: -1 to go on, else the exit code (2 on a
  // usage error, 0 after the answer).
  int parse_or_answer(int argc, char** argv, Args& out) const {
    if (!parse(argc, argv, out)) return 2;
    if (out.has("--help")) {
      print_usage(stdout);
      return 0;
    }
    if (out.has("--version")) {
      print_version(program.c_str());
      return 0;
    }
    return -1;
  }
};

}  // namespace auger
