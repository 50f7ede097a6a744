// augerd's entry: arguments, the configuration and the start-up checks, then the daemon
// (daemon.hpp). Exit codes (docs/daemon.md): 0 stopped by a signal; 1 a start-up failure that
// may pass on a retry (a module unplugged or not answering, a socket in use); 2 a configuration
// or usage error, which the service does not restart (RestartPreventExitStatus=2).
#include <csignal>
#include <cstdio>
#include <optional>
#include <string>

#include "auger/args.hpp"
#include "auger/effect.hpp"
#include "auger/model_file.hpp"
#include "auger/online_estimator.hpp"
#include "config.hpp"
#include "daemon.hpp"

namespace {

constexpr int kExitOk = 0, kExitStartup = 1, kExitConfig = 2;

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

const auger::CommandLine kCli{
    "augerd", "[OPTIONS]",
    "The robot daemon: the four modules, the 100 Hz loop, the sockets and the log (docs/daemon.md).\n",
    {{"--config", "PATH", "configuration file (default /etc/auger/augerd.toml)"},
     {"--check", "", "check the configuration, the model and what start-up needs (ports, log\n"
                     "directory, socket paths, groups), then exit: 0 ready, 1 not now, 2 an error"}},
    "Exit 0: stopped by a signal; 1: a start-up failure that may pass (a port missing; the service\n"
    "restarts it); 2: a configuration or usage error (the service does not restart it).\n"};

void usage(std::FILE* f) { kCli.print_usage(f); }

}  // namespace

int main(int argc, char** argv) {
  using namespace augerd;
  std::string config_path = "/etc/auger/augerd.toml";
  bool check_only = false;
  auger::Args args;
  if (const int rc = kCli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
  if (!args.positional.empty()) {
    std::fprintf(stderr, "augerd: unknown argument '%s'\n", args.positional[0].c_str());
    usage(stderr);
    return kExitConfig;
  }
  config_path = args.get("--config", config_path);
  check_only = args.has("--check");
  DaemonConfig cfg;
  std::optional<auger::Model> model;
  try {
    cfg = load_daemon_config(config_path);
    const auger::ModelFile& mf = cfg.model;
    model = auger::build_model(mf, cfg.terrain);
    // The effects' parameters marked online (more than the estimator takes is an error here).
    const std::size_t n_online = auger::online_effect_params(mf, auger::EffectRegistry::builtin()).size();
    if (n_online > 0 && !cfg.online.enabled)
      std::fprintf(stderr, "augerd: note: %s marks %zu effect parameter(s) online, but [online] is off: they keep the "
                           "file's values\n", cfg.model_file.c_str(), n_online);
    if (n_online > 0 && cfg.online.enabled)
      for (std::string notes = auger::online_effect_caveats(mf, auger::EffectRegistry::builtin()); !notes.empty();) {
        const std::size_t nl = notes.find('\n');
        std::fprintf(stderr, "augerd: note: %s\n", notes.substr(0, nl).c_str());
        notes.erase(0, nl + 1);
      }
    if (cfg.controller.effect_feedforward) {
      // Which effects' forces the controller feeds forward: whether is fixed per effect, not per state.
      std::string fed;
      auger::Vec3 f;
      for (const auto& e : model->effects)
        if (e->feedforward_force(*model, auger::Vec3::Zero(), auger::Vec3::Zero(), f)) fed += (fed.empty() ? "" : ", ") + e->id();
      std::fprintf(stderr, "augerd: note: [control] effect_feedforward: %s\n",
                   fed.empty() ? ("no effect of " + cfg.model_file + " has a force to feed forward (docs/daemon.md "
                                  "\"Effect feedforward\"): the PID's force alone").c_str()
                               : ("the controller feeds forward the force of " + fed + " (" + cfg.model_file + ")").c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "augerd: configuration error: %s\n", e.what());
    return kExitConfig;
  }
  if (check_only) std::printf("augerd: %s: the configuration and the model are valid\n", config_path.c_str());
  // Before anything is opened: a configuration certain to fail is reported whole, once, and
  // exits 2 (final for the service); a missing port may appear later (exit 1, retried).
  int code = kExitOk;
  for (const StartupProblem& p : check_startup(cfg)) {
    std::fprintf(stderr, "augerd: %s: %s\n", p.final ? "configuration error" : "not ready", p.text.c_str());
    code = p.final ? kExitConfig : (code == kExitOk ? kExitStartup : code);
  }
  if (code != kExitOk) return code;
  if (check_only) {
    std::printf("augerd: everything start-up needs is in place\n");
    return kExitOk;
  }
  struct sigaction sa{};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
  // A file-size limit reached by the log is a write error to survive, like a full disk.
  std::signal(SIGXFSZ, SIG_IGN);
  try {
    Daemon d(cfg, std::move(*model));
    d.open_modules();
    d.open_sockets();
    d.open_log();
    d.open_ros2();
    std::fprintf(stderr, "augerd: running (commands %s, sensors %s)\n", cfg.commands_socket.c_str(),
                 cfg.sensors_socket.c_str());
    d.run(&g_stop);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "augerd: %s\n", e.what());
    return kExitStartup;
  }
  std::fprintf(stderr, "augerd: stopped\n");
  return kExitOk;
}
