// augerd's online estimate beside the offline fit (report_online.hpp) and its report section.
#include "report_online.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "auger/online_estimator.hpp"
#include "report.hpp"

namespace auger::wb {

namespace {

const FitParam& param(const std::vector<FitParam>& offline, const std::string& name) {
  for (const FitParam& p : offline)
    if (p.name == name) return p;
  throw std::invalid_argument("the offline fit has no " + name);
}

std::string g(double v, int digits) {
  if (!std::isfinite(v)) return "&ndash;";
  char b[32];
  std::snprintf(b, sizeof b, "%.*g", digits, v);
  return b;
}
}  // namespace

std::vector<std::string> online_held(const Dataset& d) {
  std::vector<std::string> held;
  if (d.online_value.empty()) return held;
  for (int p = 0; p < 5; ++p) {
    const auto pp = std::size_t(p);
    double max_rel = 0;
    for (std::size_t i = 0; i < d.size(); ++i)
      if (std::isfinite(d.online_sd[i][pp]) && d.online_value[i][pp] > 0)
        max_rel = std::max(max_rel, d.online_sd[i][pp] / d.online_value[i][pp]);
    if (max_rel <= kHeldRelSd) held.push_back(online_param_name(p));
  }
  return held;
}

std::vector<OnlineAgreement> online_agreement(const Dataset& d, std::size_t k, const std::vector<FitParam>& offline) {
  if (d.online_value.empty()) throw std::invalid_argument(d.path + " has no on_* columns (augerd without [online])");
  const std::vector<std::string> held = online_held(d);
  std::vector<OnlineAgreement> out;
  for (int p = 0; p < 5; ++p) {
    const auto pp = std::size_t(p);
    const FitParam& f = param(offline, online_param_name(p));
    OnlineAgreement a;
    a.name = online_param_name(p), a.unit = online_param_unit(p);
    a.online = d.online_value[k][pp], a.online_sd = d.online_sd[k][pp];
    a.offline = f.value, a.offline_sd = f.sigma;
    a.held = std::find(held.begin(), held.end(), a.name) != held.end();
    double prior_sd = 0;
    for (const auto& sd : d.online_sd)
      if (std::isfinite(sd[pp])) prior_sd = std::max(prior_sd, sd[pp]);
    a.informed = !a.held && a.online_sd < 0.5 * prior_sd;
    if (a.informed) a.z = std::fabs(a.online - a.offline) / std::hypot(a.online_sd, a.offline_sd);
    out.push_back(a);
  }
  return out;
}

Section online_section(const Findings& f, ChartSet& charts) {
  const Dataset& d = f.d;
  const std::size_t last = d.size() - 1;
  const std::vector<OnlineAgreement> rows = online_agreement(d, last, f.offline);
  const std::vector<std::string> held = online_held(d);
  std::string hold_arg;
  for (const std::string& n : held) hold_arg += (hold_arg.empty() ? " --hold " : ",") + n;
  std::ostringstream h;
  h << "<p>augerd estimated the terrain while it drove (<code>[online]</code>, the log's <code>on_*</code> columns: "
       "docs/daemon.md \"Online identification\"). Beside it the offline fit of the same log, <code>auger fit "
    << html_escape(d.path) << " --add paper_params" << hold_arg
    << "</code> (sigma and D over the whole log, eqs. (15)-(17)"
    << (held.empty() ? "" : ", holding what the online estimate held at the configured values") << "). The "
       "online estimate at the end of the log remembers the last few seconds of excited driving; the offline fit "
       "spans the whole log: they are comparable where the ground did not change. <i>z</i> is the difference over "
       "the combined standard uncertainty; up to 2 they agree (95 %). A parameter the online data did not inform (its SD "
       "above half its prior's) is not compared.</p>\n"
       "<table class=online-agreement><tr><th class=l>parameter</th><th>online at "
    << g(d.t_s[last], 4) << " s (&plusmn; SD)</th><th>offline fit (&plusmn; SD)</th><th>z</th><th class=l>unit</th></tr>\n";
  for (const OnlineAgreement& a : rows) {
    h << "<tr><td class=l>" << html_escape(a.name) << "</td><td>" << g(a.online, 4) << " &plusmn; " << g(a.online_sd, 2)
      << "</td><td>" << g(a.offline, 4) << " &plusmn; " << g(a.offline_sd, 2) << "</td><td";
    if (a.held) h << " class=l>held online and offline (the configured value, not estimated)";
    else if (!a.informed) h << " class=l>not informed online (its prior)";
    else h << (a.z > 2 ? " class=flag>" : ">") << g(a.z, 2);
    h << "</td><td class=l>" << html_escape(a.unit) << "</td></tr>\n";
  }
  h << "</table>\n";
  // One time chart per parameter: the online estimate with its +-SD band, the offline fit's value
  // and band as constants.
  for (int p = 0; p < 5; ++p) {
    const auto pp = std::size_t(p);
    const OnlineAgreement& a = rows[pp];
    Chart ch;
    ch.title = "Online estimate of " + a.name + (a.held ? " (held online)" : "");
    ch.xlabel = "t (s)";
    ch.ylabel = a.name + " (" + a.unit + ")";
    ch.group = "time";
    ch.x = d.t_s;
    ChartSeries on{"online", {}, "line", "#1f77b4"}, lo{"online - SD", {}, "thin", "#1f77b4"},
        hi{"online + SD", {}, "thin", "#1f77b4"};
    for (std::size_t i = 0; i < d.size(); ++i) {
      on.y.push_back(d.online_value[i][pp]);
      lo.y.push_back(d.online_value[i][pp] - d.online_sd[i][pp]);
      hi.y.push_back(d.online_value[i][pp] + d.online_sd[i][pp]);
    }
    ChartSeries off{"offline fit", std::vector<double>(d.size(), a.offline), "dashed", "#2ca02c"},
        off_lo{"offline - SD", std::vector<double>(d.size(), a.offline - a.offline_sd), "thin", "#2ca02c"},
        off_hi{"offline + SD", std::vector<double>(d.size(), a.offline + a.offline_sd), "thin", "#2ca02c"};
    ch.series = {on, lo, hi, off, off_lo, off_hi};
    h << charts.add(std::move(ch));
  }
  return {"online", "Online estimate", h.str()};
}

}  // namespace auger::wb
