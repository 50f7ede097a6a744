// The client of augerd's sockets (docs/daemon-protocol.md):
//   auger cmd [--socket PATH] LINE...     one answer per line, printed; exit 1 on any error
//   auger sensor [--socket PATH] LINE...  only errors come back; exit 1 if any
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "auger/args.hpp"
#include "augerd_client.hpp"
#include "subcommand.hpp"

namespace {

using auger::io::AugerdClient;
using auger::io::kDefaultCommandsSocket;
using auger::io::kDefaultSensorsSocket;

auger::CommandLine client_cli(const std::string& mode) {
  const bool cmd = mode == "cmd";
  return {"auger " + mode, "[OPTIONS] LINE...",
          std::string("Sends each LINE to augerd's ") + (cmd ? "commands" : "sensors") +
              " socket and prints its answers (docs/daemon-protocol.md),\n"
              "e.g. auger cmd enable 'vel 0.05 0 0' status\n",
          {{"--socket", "PATH",
            std::string("the socket (default ") + (cmd ? kDefaultCommandsSocket : kDefaultSensorsSocket) + ")"}},
          "Exit 0: every line answered ok; 1: augerd answered an error; 2: bad usage; 3: augerd not reached.\n"};
}

int run_client(int argc, char** argv) {
  const std::string mode = argv[0];
  std::string path = mode == "cmd" ? kDefaultCommandsSocket : kDefaultSensorsSocket;
  std::vector<std::string> lines;
  const auger::CommandLine cli = client_cli(mode);
  auger::Args a;
  if (const int rc = cli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
  path = a.get("--socket", path);
  lines = a.positional;
  if (lines.empty()) return cli.print_usage(stderr), 2;
  std::unique_ptr<AugerdClient> c;
  try {
    c = std::make_unique<AugerdClient>(path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger: %s\n", e.what());
    return 3;
  }
  int status = 0;
  std::string answer;
  if (mode == "cmd") {
    // One line, one answer, in order.
    for (const auto& l : lines) {
      if (!c->send_line(l) || !c->read_line(answer)) {
        std::fprintf(stderr, "auger: no answer from %s to '%s'\n", path.c_str(), l.c_str());
        return 3;
      }
      std::printf("%s\n", answer.c_str());
      if (answer.rfind("error:", 0) == 0) status = 1;
    }
  } else {
    // Valid sensor lines get no answer: send all, shut our side, print what comes back
    // until augerd closes the connection.
    for (const auto& l : lines)
      if (!c->send_line(l)) {
        std::fprintf(stderr, "auger: cannot send to %s\n", path.c_str());
        return 3;
      }
    c->shutdown_sending();
    while (c->read_line(answer)) {
      std::printf("%s\n", answer.c_str());
      if (answer.rfind("error:", 0) == 0) status = 1;
    }
  }
  std::fflush(stdout);
  return status;
}

}  // namespace

std::vector<auger::cli::Subcommand> auger::cli::client_subcommands() {
  return {
      {"cmd", "send command lines to augerd, print its answers", run_client},
      {"sensor", "send sensor lines (pose, imu) to augerd", run_client},
  };
}
