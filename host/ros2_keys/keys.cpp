// `auger ros2-keys` (ros2_keys.hpp): the keystore's files, made by the openssl program with
// argument vectors (host/io process.hpp: no shell), its paths absolute so that none reads as an
// option, the names in certificate subjects checked (check_name) so that none adds a field.
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include "auger/args.hpp"
#include "auger/daemon_config.hpp"
#include "process.hpp"
#include "ros2_keys.hpp"

namespace auger::ros2_keys {
namespace {

namespace fs = std::filesystem;

const CommandLine kCli{
    "auger ros2-keys",
    "create KEYSTORE --config AUGERD_TOML | peer KEYSTORE NAME --config AUGERD_TOML [--read-only]",
    "The DDS Security keystore of augerd's ROS 2 interface (docs/ros2.md \"Who may command the robot\"),\n"
    "in SROS2's layout, made with openssl:\n"
    "  create  a new keystore: its CA (private/ca.key.pem: keep it off the robot), the governance\n"
    "          (only authenticated participants, everything encrypted) and augerd's enclave\n"
    "          (enclaves/augerd), allowed exactly the topics of [ros2] in AUGER_TOML, in its domain\n"
    "  peer    the enclave of another participant, enclaves/NAME: it may publish augerd's inputs\n"
    "          (cmd_vel, poses, IMU) and subscribe its outputs; --read-only: subscribe only\n"
    "Certificates and permissions are valid for --days from now. After changing [ros2]'s domain,\n"
    "namespace or topics, make a new keystore.\n",
    {{"--config", "PATH", "augerd's configuration (its [ros2] section: domain, namespace, topics)"},
     {"--read-only", "", "peer: may only subscribe augerd's outputs"},
     {"--days", "N", "validity of certificates and permissions (default 3650)"}},
    "Exit 0: made; 1: openssl failed (its output is shown); 2: bad usage or configuration, or the\n"
    "keystore (create) or enclave (peer) exists already.\n"};

constexpr int kOk = 0, kFailed = 1, kUsage = 2;

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

bool write_file(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << text;
  f.close();
  if (!f) std::fprintf(stderr, "auger ros2-keys: cannot write %s: %s\n", path.c_str(), std::strerror(errno));
  return bool(f);
}

// A certificate serial number from the kernel's random source (x509 -set_serial).
std::string random_serial() {
  unsigned char b[8] = {};
  std::ifstream("/dev/urandom", std::ios::binary).read(reinterpret_cast<char*>(b), sizeof b);
  char hex[3 + 2 * sizeof b] = "0x";
  for (std::size_t i = 0; i < sizeof b; ++i) std::snprintf(hex + 2 + 2 * i, 3, "%02x", b[i] & (i == 0 ? 0x7f : 0xff));
  return hex;
}

class Keystore {
 public:
  Keystore(std::string dir, int days) : dir_(std::move(dir)), days_(days), log_(dir_ + "/.openssl.log") {}
  const std::string& dir() const { return dir_; }
  std::string ca_key() const { return dir_ + "/private/ca.key.pem"; }
  std::string ca_cert() const { return dir_ + "/public/ca.cert.pem"; }
  std::string governance() const { return dir_ + "/enclaves/governance.p7s"; }

  // openssl ARGS; on failure its output and what was being made.
  bool openssl(const std::vector<std::string>& args, const std::string& what) const {
    const int status = io::run_program("openssl", args, log_, log_);
    if (io::program_succeeded(status)) return true;
    std::fprintf(stderr, "auger ros2-keys: openssl failed making %s%s\n%s", what.c_str(),
                 status < 0 ? " (is the openssl program installed? Debian package openssl)" : "",
                 slurp(log_).c_str());
    return false;
  }
  bool new_key(const std::string& path) const {
    if (!openssl({"genpkey", "-algorithm", "EC", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-out", path}, path))
      return false;
    ::chmod(path.c_str(), 0600);
    return true;
  }
  bool sign(const std::string& xml_path, const std::string& p7s_path) const {
    return openssl({"smime", "-sign", "-text", "-in", xml_path, "-out", p7s_path, "-signer", ca_cert(), "-inkey",
                    ca_key()},
                   p7s_path);
  }
  bool create_ca(int domain_id) const {
    std::error_code ec;
    for (const char* d : {"public", "private", "enclaves"}) fs::create_directories(dir_ + "/" + d, ec);
    ::chmod((dir_ + "/private").c_str(), 0700);
    const std::string gov = dir_ + "/enclaves/governance.xml";
    return new_key(ca_key()) &&
           openssl({"req", "-x509", "-new", "-key", ca_key(), "-out", ca_cert(), "-days", std::to_string(days_),
                    "-sha256", "-subj", "/CN=auger_ros2_ca", "-addext", "basicConstraints=critical,CA:TRUE", "-addext",
                    "keyUsage=critical,digitalSignature,keyCertSign,cRLSign"},
                   ca_cert()) &&
           write_file(gov, governance_xml(domain_id)) && sign(gov, governance());
  }
  // enclaves/NAME: key, certificate (CN=NAME) signed by the CA, the CA's certificate as identity
  // and permissions CA, the governance, the permissions signed.
  bool create_enclave(const std::string& name, int domain_id, const std::vector<std::string>& publish,
                      const std::vector<std::string>& subscribe) const {
    const std::string e = dir_ + "/enclaves/" + name;
    std::error_code ec;
    fs::create_directories(e, ec);
    if (ec) {
      std::fprintf(stderr, "auger ros2-keys: cannot create %s: %s\n", e.c_str(), ec.message().c_str());
      return false;
    }
    const std::time_t now = std::time(nullptr);
    const std::string csr = e + "/cert.csr";
    const bool ok =
        new_key(e + "/key.pem") &&
        openssl({"req", "-new", "-key", e + "/key.pem", "-subj", "/CN=" + name, "-out", csr}, csr) &&
        openssl({"x509", "-req", "-in", csr, "-CA", ca_cert(), "-CAkey", ca_key(), "-set_serial", random_serial(),
                 "-days", std::to_string(days_), "-sha256", "-out", e + "/cert.pem"},
                e + "/cert.pem") &&
        copy(ca_cert(), e + "/identity_ca.cert.pem") && copy(ca_cert(), e + "/permissions_ca.cert.pem") &&
        copy(governance(), e + "/governance.p7s") &&
        write_file(e + "/permissions.xml", permissions_xml(name, "CN=" + name, domain_id, publish, subscribe, now,
                                                           now + std::time_t(days_) * 86400)) &&
        sign(e + "/permissions.xml", e + "/permissions.p7s");
    fs::remove(csr, ec);
    return ok;
  }
  static bool copy(const std::string& from, const std::string& to) {
    std::error_code ec;
    fs::copy_file(from, to, fs::copy_options::overwrite_existing, ec);
    if (ec)
      std::fprintf(stderr, "auger ros2-keys: cannot copy %s to %s: %s\n", from.c_str(), to.c_str(),
                   ec.message().c_str());
    return !ec;
  }
  void done() const {
    std::error_code ec;
    fs::remove(log_, ec);
  }

 private:
  std::string dir_;
  int days_;
  std::string log_;
};

std::vector<std::string> dds_names(const std::vector<std::string>& ros_names) {
  std::vector<std::string> out;
  for (const auto& n : ros_names) out.push_back(ros2::dds_topic_name(n));
  return out;
}

// KEYSTORE as an absolute path (so that openssl never takes it for an option); for create it
// must not exist or be an empty directory, for peer it must hold a CA.
bool keystore_path(const std::string& given, bool create, std::string& out) {
  std::error_code ec;
  const fs::path p = fs::absolute(given, ec).lexically_normal();
  out = p.string();
  if (!out.empty() && out.size() > 1 && out.back() == '/') out.pop_back();
  if (create) {
    if (fs::exists(p, ec) && !(fs::is_directory(p, ec) && fs::is_empty(p, ec))) {
      std::fprintf(stderr, "auger ros2-keys: %s exists and is not an empty directory; give a new one\n", out.c_str());
      return false;
    }
    fs::create_directories(p, ec);
    if (ec) {
      std::fprintf(stderr, "auger ros2-keys: cannot create %s: %s\n", out.c_str(), ec.message().c_str());
      return false;
    }
    return true;
  }
  for (const char* f : {"/private/ca.key.pem", "/public/ca.cert.pem", "/enclaves/governance.p7s"})
    if (!fs::exists(out + f, ec)) {
      std::fprintf(stderr, "auger ros2-keys: %s%s is missing: not a keystore of `auger ros2-keys create`\n",
                   out.c_str(), f);
      return false;
    }
  return true;
}

}  // namespace

int run(int argc, char** argv) {
  Args a;
  if (const int rc = kCli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
  const auto& pos = a.positional;
  const bool create = !pos.empty() && pos[0] == "create", peer = !pos.empty() && pos[0] == "peer";
  if (!(create && pos.size() == 2) && !(peer && pos.size() == 3)) {
    kCli.print_usage(stderr);
    return kUsage;
  }
  if (!a.has("--config")) {
    std::fprintf(stderr, "auger ros2-keys: --config AUGERD_TOML is needed (the topics and domain to allow)\n");
    return kUsage;
  }
  if (create && a.has("--read-only")) {
    std::fprintf(stderr, "auger ros2-keys: --read-only is for peers (augerd's enclave publishes its outputs)\n");
    return kUsage;
  }
  double days = 3650;
  if (!a.number("auger ros2-keys", "--days", 3650, days)) return kUsage;
  if (days < 1 || days > 36500 || days != double(int(days))) {
    std::fprintf(stderr, "auger ros2-keys: --days must be a whole number of days, 1..36500\n");
    return kUsage;
  }
  const std::string name = peer ? pos[2] : ros2::kEnclave;
  if (const std::string why = check_name(name); !why.empty()) {
    std::fprintf(stderr, "auger ros2-keys: participant name '%s' %s\n", name.c_str(), why.c_str());
    return kUsage;
  }
  if (peer && name == ros2::kEnclave) {
    std::fprintf(stderr, "auger ros2-keys: '%s' is augerd's own enclave; give the peer another name\n", ros2::kEnclave);
    return kUsage;
  }
  ros2::Settings s;
  try {
    s = read_daemon_config(a.get("--config"), /*ros2_available=*/true, /*ros2_security_stated=*/false).ros2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger ros2-keys: %s\n", e.what());
    return kUsage;
  }
  std::string dir;
  if (!keystore_path(pos[1], create, dir)) return kUsage;
  const Keystore ks(dir, int(days));
  if (peer && fs::exists(dir + "/enclaves/" + name)) {
    std::fprintf(stderr, "auger ros2-keys: %s/enclaves/%s exists already\n", dir.c_str(), name.c_str());
    return kUsage;
  }
  const std::vector<std::string> inputs = dds_names(ros2::input_topics(s)), outputs = dds_names(ros2::output_topics(s));
  bool ok = true;
  if (create) ok = ks.create_ca(s.domain_id) && ks.create_enclave(name, s.domain_id, outputs, inputs);
  else ok = ks.create_enclave(name, s.domain_id, a.has("--read-only") ? std::vector<std::string>{} : inputs, outputs);
  if (!ok) {
    // Nothing half-made stays: create's directory was new or empty, a peer's enclave new.
    std::error_code ec;
    if (create)
      for (const auto& entry : fs::directory_iterator(dir, ec)) fs::remove_all(entry.path(), ec);
    else
      fs::remove_all(dir + "/enclaves/" + name, ec);
    return kFailed;
  }
  ks.done();
  std::printf("auger ros2-keys: made %s/enclaves/%s (domain %d; %s)\n", dir.c_str(), name.c_str(), s.domain_id,
              create ? "augerd's identity" : a.has("--read-only") ? "may subscribe augerd's outputs"
                                                                   : "may command augerd and subscribe its outputs");
  if (create)
    std::printf("next: in [ros2] of %s set keystore = \"%s\" (copy the keystore to the robot without private/);\n"
                "      then `auger ros2-keys peer %s NAME --config ...` for each machine that may command it\n",
                a.get("--config").c_str(), dir.c_str(), dir.c_str());
  else
    std::printf("next: copy %s/enclaves/%s to that machine; its DDS participant uses those files\n"
                "      (docs/ros2.md \"Who may command the robot\")\n",
                dir.c_str(), name.c_str());
  return kOk;
}

}  // namespace auger::ros2_keys
