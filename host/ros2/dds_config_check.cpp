// check_dds_config (ros2.hpp): [ros2] dds_config as Cyclone DDS will read it, before augerd
// starts. Cyclone reads a directory, /dev/null or an empty file as an empty configuration and
// silently runs on its defaults (every interface, multicast), and a file without a <Domain> for
// augerd's domain id likewise; a bad element only fails when the domain is created. So: the file
// must be a non-empty regular file, parse with Cyclone's own XML parser, have the root
// <CycloneDDS> and a <Domain> for the domain id, leave DDS Security to [ros2] keystore, and then
// Cyclone itself must accept it (a domain is created and deleted; nothing is sent without a
// participant).
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <dds/dds.h>
#include <dds/ddsrt/xmlparser.h>

#include "ros2.hpp"

namespace auger::ros2 {
namespace {

constexpr long kMaxBytes = 1 << 20;  // a Cyclone configuration is a few kB

struct Scan {
  std::string domain_id;
  std::vector<std::string> open;  // the elements open at this point
  std::string root;
  bool domain_for_us = false;     // a <Domain> whose Id is absent, "any" or ours
  bool this_domain_for_us = false;
  int security_line = 0;          // the first <Security>, 0 none
  std::string error;
  int error_line = 0;
};

bool is(const std::string& a, const char* b) { return strcasecmp(a.c_str(), b) == 0; }

std::string trimmed(std::string v) {
  while (!v.empty() && std::isspace(static_cast<unsigned char>(v.back()))) v.pop_back();
  while (!v.empty() && std::isspace(static_cast<unsigned char>(v.front()))) v.erase(0, 1);
  return v;
}

// Cyclone's configuration names are case-insensitive; a <Domain> is a child of the root.
int on_open(void* varg, uintptr_t, uintptr_t*, const char* name, int line) {
  auto* s = static_cast<Scan*>(varg);
  if (s->open.empty()) s->root = name;
  s->open.push_back(name);
  if (s->open.size() == 2 && is(name, "Domain")) s->this_domain_for_us = true;  // no Id: any domain
  if (is(name, "Security") && s->security_line == 0) s->security_line = line;
  return 0;
}

int on_attr(void* varg, uintptr_t, const char* name, const char* value, int) {
  auto* s = static_cast<Scan*>(varg);
  if (s->open.size() == 2 && is(s->open.back(), "Domain") && is(name, "Id")) {
    const std::string v = trimmed(value);
    s->this_domain_for_us = is(v, "any") || v == s->domain_id;
  }
  return 0;
}

int on_data(void*, uintptr_t, const char*, int) { return 0; }

int on_close(void* varg, uintptr_t, int) {
  auto* s = static_cast<Scan*>(varg);
  if (s->open.size() == 2 && is(s->open.back(), "Domain")) s->domain_for_us |= s->this_domain_for_us;
  s->open.pop_back();
  return 0;
}

void on_error(void* varg, const char* msg, int line) {
  auto* s = static_cast<Scan*>(varg);
  if (s->error.empty()) s->error = msg, s->error_line = line;
}

}  // namespace

std::vector<std::string> check_dds_config(const Settings& settings) {
  std::vector<std::string> out;
  if (!settings.enabled || settings.dds_config.empty()) return out;
  const std::string& p = settings.dds_config;
  const std::string what = "[ros2] dds_config " + p;
  const std::string defaults = ": Cyclone DDS would silently run on its defaults (every interface, multicast)";
  if (p.find(',') != std::string::npos) {
    out.push_back(what + ": has a ',', which Cyclone DDS reads as a separator between two files; rename it");
    return out;
  }
  struct stat st;
  if (::stat(p.c_str(), &st) != 0) {
    out.push_back(what + ": " + std::strerror(errno));
    return out;
  }
  if (S_ISDIR(st.st_mode)) out.push_back(what + " is a directory, not a Cyclone DDS XML file" + defaults);
  else if (!S_ISREG(st.st_mode)) out.push_back(what + " is not a regular file (a device or a pipe)" + defaults);
  else if (st.st_size == 0) out.push_back(what + " is empty" + defaults);
  else if (st.st_size > kMaxBytes)
    out.push_back(what + " has " + std::to_string(st.st_size) + " bytes (at most 1 MiB)");
  if (!out.empty()) return out;
  std::FILE* f = std::fopen(p.c_str(), "r");
  if (!f) {
    out.push_back(what + ": " + std::strerror(errno));
    return out;
  }
  Scan s;
  s.domain_id = std::to_string(settings.domain_id);
  const ddsrt_xmlp_callbacks cb{on_open, on_attr, on_data, on_close, on_error};
  ddsrt_xmlp_state* x = ddsrt_xmlp_new_file(f, &s, &cb);
  const int rc = ddsrt_xmlp_parse(x);
  ddsrt_xmlp_free(x);
  std::fclose(f);
  const std::string at = p + ":";
  if (rc < 0 || !s.error.empty()) {
    out.push_back(at + std::to_string(s.error_line) + ": [ros2] dds_config is not well-formed XML: " +
                  (s.error.empty() ? "parse error" : trimmed(s.error)));
    return out;
  }
  if (s.root.empty()) out.push_back(what + " has no XML element" + defaults);
  else if (!is(s.root, "CycloneDDS"))
    out.push_back(what + ": the root element is <" + s.root + ">, not <CycloneDDS>: not a Cyclone DDS configuration");
  else if (!s.domain_for_us)
    out.push_back(what + " has no <Domain> for domain " + s.domain_id + " (Id=\"any\" or Id=\"" + s.domain_id +
                  "\")" + defaults);
  if (s.security_line > 0)
    out.push_back(at + std::to_string(s.security_line) +
                  ": [ros2] dds_config has a <Security> section: augerd's DDS Security comes from [ros2] keystore "
                  "(auger ros2-keys) alone; remove it");
  if (!out.empty()) return out;
  // Cyclone's own verdict on every element and value (it prints what it refuses).
  const dds_entity_t d = dds_create_domain(dds_domainid_t(settings.domain_id), ("file://" + p).c_str());
  if (d < 0)
    out.push_back(what + ": Cyclone DDS refuses it (" + dds_strretcode(d) + "; its message is above)");
  else
    dds_delete(d);
  return out;
}

}  // namespace auger::ros2
