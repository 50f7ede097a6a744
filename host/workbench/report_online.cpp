// augerd's online estimate beside the offline fit (report_online.hpp) and its report section.
#include "report_online.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "auger/online_estimator.hpp"
#include "report.hpp"

namespace auger::wb {

namespace {
const char* const kRatioUnits[3] = {"N/rpm per N/(m/s)", "N/rpm per N/(m/s)", "N/rpm per N m/(rad/s)"};

const FitParam& param(const std::vector<FitParam>& offline, const std::string& name) {
  for (const FitParam& p : offline)
    if (p.name == name) return p;
  throw std::invalid_argument("the offline fit has no " + name);
}

double z_of(double a, double sa, double b, double sb) { return std::fabs(a - b) / std::hypot(sa, sb); }

std::string g(double v, int digits) {
  if (!std::isfinite(v)) return "&ndash;";
  char b[32];
  std::snprintf(b, sizeof b, "%.*g", digits, v);
  return b;
}
}  // namespace

std::vector<OnlineAgreement> online_agreement(const Dataset& d, std::size_t k, const std::vector<FitParam>& offline) {
  if (d.online_value.empty()) throw std::invalid_argument(d.path + " has no on_* columns (augerd without [online])");
  std::vector<OnlineAgreement> out;
  bool held[5];
  for (int p = 0; p < 5; ++p) {
    const auto pp = std::size_t(p);
    // Held: the SD never rises above kHeldRelSd of the value (it returns to the prior at a change).
    double max_rel = 0;
    for (std::size_t i = 0; i < d.size(); ++i)
      if (std::isfinite(d.online_sd[i][pp]) && d.online_value[i][pp] > 0)
        max_rel = std::max(max_rel, d.online_sd[i][pp] / d.online_value[i][pp]);
    held[p] = max_rel <= kHeldRelSd;
    const FitParam& f = param(offline, online_param_name(p));
    OnlineAgreement a;
    a.name = online_param_name(p), a.unit = online_param_unit(p);
    a.online = d.online_value[k][pp], a.online_sd = d.online_sd[k][pp];
    a.offline = f.value, a.offline_sd = f.sigma;
    a.held = held[p];
    out.push_back(a);
  }
  out[kSigmaLong].via_ratio = held[kDx];
  out[kSigmaLat].via_ratio = held[kDy] && held[kDpsi];
  for (OnlineAgreement& a : out)
    if (!a.held && !a.via_ratio) a.z = z_of(a.online, a.online_sd, a.offline, a.offline_sd);
  for (int j = 0; j < 3; ++j) {
    const int si = online_sigma_of_dof(j), di = online_drag_of_dof(j);  // the online regression's rows
    if (!held[di] || held[si]) continue;
    const OnlineAgreement &s = out[std::size_t(si)], &dd = out[std::size_t(di)];
    OnlineAgreement a;
    a.name = std::string(online_param_name(si)) + " / " + online_param_name(di);
    a.unit = kRatioUnits[j];
    a.online = s.online / dd.online, a.online_sd = s.online_sd / dd.online;
    a.offline = s.offline / dd.offline;
    a.offline_sd = a.offline * std::hypot(s.offline_sd / s.offline, dd.offline_sd / dd.offline);
    a.z = z_of(a.online, a.online_sd, a.offline, a.offline_sd);
    out.push_back(a);
  }
  return out;
}

Section online_section(const Findings& f, ChartSet& charts) {
  const Dataset& d = f.d;
  const std::size_t last = d.size() - 1;
  const std::vector<OnlineAgreement> rows = online_agreement(d, last, f.offline);
  std::ostringstream h;
  h << "<p>augerd estimated the terrain while it drove (<code>[online]</code>, the log's <code>on_*</code> columns: "
       "docs/daemon.md \"Online identification\"). Beside it the offline fit of the same log, <code>auger fit "
    << html_escape(d.path) << " --add paper_params</code> (sigma and D over the whole log, eqs. (15)-(17)). The "
       "online estimate at the end of the log remembers the last few seconds of excited driving; the offline fit "
       "spans the whole log: they are comparable where the ground did not change. <i>z</i> is the difference over "
       "the combined standard uncertainty; up to 2 they agree (95 %).</p>\n"
       "<table class=online-agreement><tr><th class=l>parameter</th><th>online at "
    << g(d.t_s[last], 4) << " s (&plusmn; SD)</th><th>offline fit (&plusmn; SD)</th><th>z</th><th class=l>unit</th></tr>\n";
  for (const OnlineAgreement& a : rows) {
    h << "<tr><td class=l>" << html_escape(a.name) << "</td><td>" << g(a.online, 4) << " &plusmn; " << g(a.online_sd, 2)
      << "</td><td>" << g(a.offline, 4) << " &plusmn; " << g(a.offline_sd, 2) << "</td><td";
    if (a.held) h << " class=l>held online (the configured value, not estimated)";
    else if (a.via_ratio) h << " class=l>its D held online: compared as sigma / D";
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
