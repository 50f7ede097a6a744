// Argument parsing shared by the workbench's subcommands: positional arguments, `--flag`,
// `--key VALUE`; an unknown option is a usage error naming it.
#pragma once

#include <cstdio>
#include <set>
#include <string>
#include <vector>

namespace auger::wb {

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
};

// flags: options without a value; valued: options with one. Returns false (and prints) on error.
inline bool parse_args(int argc, char** argv, const std::set<std::string>& flags,
                       const std::set<std::string>& valued, Args& out) {
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
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
            std::fprintf(stderr, "auger %s: option %s needs a value\n", argv[0], a.c_str());
            return false;
          }
          value = argv[++i];
        }
        out.options.push_back({a, value});
      } else {
        std::fprintf(stderr, "auger %s: unknown option '%s'\n", argv[0], a.c_str());
        return false;
      }
    } else {
      out.positional.push_back(a);
    }
  }
  return true;
}

}  // namespace auger::wb
