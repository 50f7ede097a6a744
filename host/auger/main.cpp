// auger: the project's command-line tool. `auger --help` lists the subcommands;
// `auger SUBCOMMAND --help` explains one.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "subcommand.hpp"

namespace {

std::vector<auger::cli::Subcommand> all_subcommands() {
  std::vector<auger::cli::Subcommand> all;
  for (auto group : {auger::cli::workbench_subcommands, auger::cli::operator_subcommands,
                     auger::cli::interop_subcommands, auger::cli::client_subcommands})
    for (const auto& s : group()) all.push_back(s);
  return all;
}

int usage(std::FILE* f, int code) {
  std::fprintf(f, "usage: auger SUBCOMMAND [ARGS...]   (auger SUBCOMMAND --help for one)\n\n");
  for (const auto& s : all_subcommands())
    std::fprintf(f, "  auger %-9s %s\n      %s\n", s.name, s.usage, s.summary);
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage(stderr, 2);
  const std::string name = argv[1];
  if (name == "--help" || name == "-h" || name == "help") return usage(stdout, 0);
  for (const auto& s : all_subcommands())
    if (name == s.name) return s.run(argc - 1, argv + 1);
  std::fprintf(stderr, "auger: unknown subcommand '%s'\n", name.c_str());
  return usage(stderr, 2);
}
