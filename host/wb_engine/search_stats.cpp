// The search's statistics and words (fitting.hpp): segments, the effective sample size, errors
// over segments (and a terrain change placed in a held-out gap), flags of implausible or
// unidentified values, plain-words descriptions, which experiment tells two effects apart, the
// candidates for a log; and the threads that fit them.
#include "fitting.hpp"

#include "auger/term_form.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <exception>
#include <limits>
#include <mutex>
#include <set>
#include <thread>

namespace auger::wb {
namespace search {

// ---------------------------------------------------------------- threads
namespace {

// The first exception of jobs run on several threads (the others are dropped), for the caller.
struct FirstError {
  std::mutex m;
  std::exception_ptr e;
  void keep(std::exception_ptr x) {
    std::lock_guard<std::mutex> lock(m);
    if (!e) e = std::move(x);
  }
  void rethrow() const {
    if (e) std::rethrow_exception(e);
  }
};

// A loop that share_loop offers to idle workers: its items are taken one at a time by whoever
// runs it (its owner, and helpers), and the owner waits for the helpers' items before it returns.
struct SharedLoop {
  std::size_t n = 0;
  const std::function<void(std::size_t)>* fn = nullptr;
  std::atomic<std::size_t> next{0};
  int helpers = 0;  // in the loop now (guarded by the board's mutex)
  FirstError failed;  // an item's: the rest are skipped, the owner rethrows it
  void run() {
    for (std::size_t i; (i = next++) < n;) {
      try {
        (*fn)(i);
      } catch (...) {
        failed.keep(std::current_exception());
        next = n;
      }
    }
  }
  bool open() const { return next.load() < n; }
};

// The loops on offer, and the workers of run_parallel that wait for one. A worker with no task
// of its own left waits here while another worker of its run is still busy: that one may offer
// a loop (a change time's grid) that would otherwise run on one thread with the other idle.
struct Board {
  std::mutex m;
  std::condition_variable cv;
  std::vector<SharedLoop*> loops;
  SharedLoop* open_loop() const {
    for (SharedLoop* l : loops)
      if (l->open()) return l;
    return nullptr;
  }
};
Board& board() {
  static Board b;
  return b;
}

}  // namespace

void share_loop(std::size_t n, const std::function<void(std::size_t)>& fn) {
  SharedLoop loop;
  loop.n = n;
  loop.fn = &fn;
  Board& b = board();
  {
    std::lock_guard<std::mutex> lock(b.m);
    b.loops.push_back(&loop);
  }
  b.cv.notify_all();
  loop.run();
  std::unique_lock<std::mutex> lock(b.m);
  b.loops.erase(std::find(b.loops.begin(), b.loops.end(), &loop));
  b.cv.wait(lock, [&] { return loop.helpers == 0; });
  loop.failed.rethrow();
}

void run_parallel(int threads, const std::vector<std::size_t>& which, const std::function<int(std::size_t)>& wait_for,
                  const std::function<void(std::size_t)>& fn) {
  std::atomic<std::size_t> next{0};
  std::set<std::size_t> done;
  std::condition_variable cv;
  std::mutex m;
  Board& b = board();
  int busy = std::max(1, threads);  // workers still running tasks of `which` (under b.m)
  FirstError failed;                // a task's: rethrown once all are joined
  auto worker = [&]() {
    for (std::size_t n; (n = next++) < which.size();) {
      const std::size_t i = which[n];
      const int w = wait_for(i);
      // (Waiting is only for an index that is also run: a job scheduled earlier in `which`.)
      if (w >= 0 && std::find(which.begin(), which.end(), static_cast<std::size_t>(w)) != which.end()) {
        std::unique_lock<std::mutex> lock(m);
        cv.wait(lock, [&] { return done.count(static_cast<std::size_t>(w)) != 0; });
      }
      try {
        fn(i);
      } catch (...) {
        failed.keep(std::current_exception());
        next = which.size();  // the tasks not started are skipped
      }
      {
        std::lock_guard<std::mutex> lock(m);
        done.insert(i);
      }
      cv.notify_all();
    }
    // No task left: help with a loop on offer until every worker of this run is done. (Only
    // with more than one thread: --threads 1 keeps explain on one.)
    std::unique_lock<std::mutex> lock(b.m);
    --busy;
    b.cv.notify_all();
    for (;;) {
      b.cv.wait(lock, [&] { return busy == 0 || b.open_loop(); });
      SharedLoop* loop = b.open_loop();
      if (!loop) break;
      ++loop->helpers;
      lock.unlock();
      loop->run();
      lock.lock();
      --loop->helpers;
      b.cv.notify_all();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::max(1, threads); ++t) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  failed.rethrow();
}

// ---------------------------------------------------------------- statistics
Segments make_segments(const Dataset& d, double segment_s) {
  Segments s;
  std::size_t b = d.size();
  for (std::size_t k = 0; k < d.size(); ++k) {
    if (!is_start_row(d, k)) continue;
    if (b == d.size()) b = k;
    else if (d.t_s[k] - d.t_s[b] >= segment_s) {
      s.push_back({b, k});
      b = k;
    }
  }
  if (b < d.size()) {
    if (!s.empty() && d.t_s.back() - d.t_s[b] < 0.4 * segment_s) s.back().second = d.size();  // no stub
    else s.push_back({b, d.size()});
  }
  return s;
}

double lag1_autocorrelation(const Problem& pr, const Eigen::VectorXd& r) {
  double num = 0, den = 0;
  Eigen::Index at = 0;
  for (const LogTerm& t : pr.terms) {
    std::array<long, kChannels> last;
    last.fill(-1);
    std::size_t seg_of_last[kChannels] = {0, 0, 0, 0};
    std::size_t seg = 0;
    for (std::size_t i = 0; i < t.index.size(); ++i) {
      const auto [k, c] = t.index[i];
      while (seg + 1 < t.segs.size() && k >= t.segs[seg].second) ++seg;
      const double v = r[at + static_cast<Eigen::Index>(i)];
      den += v * v;
      const auto cc = static_cast<std::size_t>(c);
      if (last[cc] >= 0 && seg_of_last[cc] == seg) num += v * r[at + last[cc]];
      last[cc] = static_cast<long>(i);
      seg_of_last[cc] = seg;
    }
    at += static_cast<Eigen::Index>(t.size());
  }
  return den > 0 ? std::clamp(num / den, 0.0, 0.999) : 0.0;
}

double effective_n(double n, double rho) { return std::clamp(n * (1 - rho) / (1 + rho), std::min(n, 10.0), n); }

double combined_ratio(const ErrorStats& e, const Dataset& d) {
  double s = 0;
  int n = 0;
  for (int c = 0; c < kChannels; ++c)
    if (d.active[static_cast<std::size_t>(c)] && std::isfinite(e.ratio_to_noise[static_cast<std::size_t>(c)])) {
      s += e.ratio_to_noise[static_cast<std::size_t>(c)] * e.ratio_to_noise[static_cast<std::size_t>(c)];
      ++n;
    }
  return n ? std::sqrt(s / n) : kNaN;
}

ErrorStats segments_error(const Model& m, const Dataset& d, const Segments& segs, const ChannelValues& noise) {
  Prediction p;
  p.pred.assign(d.size(), ChannelValues{kNaN, kNaN, kNaN, kNaN});
  SimOptions o = sim_options_for(m);
  o.segment_s = 0;
  o.n_sub = 4;  // as the search simulates the decimated log
  for (const auto& [b, e] : segs) simulate_range(m, d, o, p, b, e);
  return error_stats(d, p, noise);
}

// A change of terrain that falls in a held-out segment: the training segments say only that it
// lies somewhere in that gap (the training cost is the same anywhere in it), and a place chosen
// at random in the gap would charge the held-out segment with up to 25 s of the wrong terrain.
// So its place inside the gap, and only that, is read from the held-out segment.
void place_changes_in_gaps(std::vector<Part>& parts, const Model& base, const Dataset& data, const Segments& fitted,
                           const Segments& judged, const ChannelValues& noise, int log) {
  for (std::size_t pi = 0; pi < parts.size(); ++pi) {
    Part& p = parts[pi];
    if (p.id != kTerrainChange || !p.entry || p.values.empty() || std::max(p.log, 0) != log) continue;
    const std::vector<double>& t = data.t_s;
    for (const auto& seg : judged) {
      const auto [b, e] = seg;
      if (e <= b + 1 || std::find(fitted.begin(), fitted.end(), seg) != fitted.end()) continue;
      const double lo = b > 0 ? t[b - 1] : -std::numeric_limits<double>::infinity();
      const double hi = e < t.size() ? t[e] : std::numeric_limits<double>::infinity();
      if (!(p.values[0] > lo && p.values[0] <= hi)) continue;
      const Segments one{seg};
      double best_t = p.values[0], best = std::numeric_limits<double>::infinity();
      constexpr int kGrid = 101;
      for (int g = 0; g <= kGrid; ++g) {
        // (g == kGrid: the place the fit chose, kept on a tie.)
        const double tc = g < kGrid ? t[b] + (t[e - 1] - t[b]) * g / (kGrid - 1) : p.values[0];
        std::vector<Part> trial = parts;
        trial[pi].values[0] = tc;
        const ErrorStats es = segments_error(build(base, trial, log), data, one, noise);
        double sum = 0;
        for (int ch = 0; ch < kChannels; ++ch) {
          const auto cc = static_cast<std::size_t>(ch);
          if (es.n[cc] && std::isfinite(es.ratio_to_noise[cc])) sum += es.ratio_to_noise[cc] * es.ratio_to_noise[cc];
        }
        if (sum < best * (1 - 1e-9)) {
          best = sum;
          best_t = tc;
        }
      }
      p.values[0] = best_t;
      break;
    }
  }
}

void flag_params(std::vector<FitParam>& params, const Part& part) {
  for (std::size_t i = 0; i < params.size() && i < part.specs.size(); ++i) {
    const ParamSpec& s = part.specs[i];
    FitParam& p = params[i];
    p.flag.clear();
    const bool searched = std::find(part.free.begin(), part.free.end(), static_cast<int>(i)) != part.free.end();
    if (!s.fitted || s.integer) continue;
    char buf[200];
    if (!searched) continue;  // held at its default: nothing was fitted
    if (i < part.at_least.size() && part.at_least[i] > 0) {
      // settle_stalls: the robot never overcame it; any larger value predicts the log the same.
      std::snprintf(buf, sizeof buf, "a lower bound: at least %.3g %s (the robot stuck against it; any larger value predicts this log the same)",
                    part.at_least[i], s.unit.c_str());
      p.flag = buf;
      continue;
    }
    auto near = [&](double bound) { return near_bound(s, p.value, bound); };
    const int end = physical_end(s, p.value);
    const bool at_lo = end < 0, at_hi = end > 0;
    if (p.value < s.physical_lower || p.value > s.physical_upper) {
      std::snprintf(buf, sizeof buf, "outside the physical range %g..%g %s", s.physical_lower, s.physical_upper,
                    s.unit.c_str());
      p.flag = buf;
    } else if ((at_lo || at_hi) && part.entry && std::isfinite(p.sigma) && p.sigma > 0.5 * std::fabs(p.value)) {
      // An effect's value that the log bounds from one side only (a blocked screw that never
      // slides says its force is at least what the others push with): a plausible value lies
      // within its uncertainty. (The paper's parameters at the end of their range are the sign
      // of an effect they have taken up, however uncertain.)
      std::snprintf(buf, sizeof buf, "not identified by this log: at the end of its physical range, %g %s, +- %.2g",
                    at_lo ? s.physical_lower : s.physical_upper, s.unit.c_str(), p.sigma);
      p.flag = buf;
    } else if (at_lo || at_hi) {
      std::snprintf(buf, sizeof buf, "at the end of its physical range, %g %s", at_lo ? s.physical_lower : s.physical_upper,
                    s.unit.c_str());
      p.flag = buf;
    } else if ((near(search_lower(s)) || near(search_upper(s))) && part.entry && std::isfinite(p.sigma) &&
               p.sigma > 0.5 * std::fabs(p.value) && (s.log_scale || p.sigma > 0.1 * std::fabs(s.typical))) {
      // At the end of the range the effect itself defines (a Stribeck speed at its shortest, a
      // level at zero) with an uncertainty over half its value: the log does not tell where it
      // lies (a level pinned at zero and known to a tenth of its typical size is zero, though).
      const bool lo = near(search_lower(s));
      std::snprintf(buf, sizeof buf, "not identified by this log: at the end of its range, %g %s, +- %.2g",
                    lo ? search_lower(s) : search_upper(s), s.unit.c_str(), p.sigma);
      p.flag = buf;
    } else if (searched && std::isfinite(p.sigma) && p.sigma > std::fabs(p.value) && p.sigma > 0.5 * std::fabs(s.typical)) {
      // (A value near zero known to a small fraction of its typical size is identified: it is zero.)
      p.flag = "uncertainty larger than the value: not identified by this log";
    }
  }
}

bool any_implausible(const std::vector<FitParam>& params) {
  for (const FitParam& p : params)
    if (p.flag.rfind("outside", 0) == 0 || p.flag.rfind("at the end", 0) == 0) return true;
  return false;
}

bool any_flag(const std::vector<FitParam>& params) {
  for (const FitParam& p : params)
    if (!p.flag.empty()) return true;
  return false;
}

std::string describe(const Part& p, const Model& base) {
  if (!p.entry && p.free.empty()) {
    char buf[300];
    std::snprintf(buf, sizeof buf,
                  "the paper's own parameters, held at its values: sigma_long %.3g N/rpm, sigma_lat %.3g N/rpm, D_x %.4g "
                  "N/(m/s), D_y %.4g N/(m/s), D_psi %.3g N m/(rad/s)",
                  p.values[0], p.values[1], p.values[2], p.values[3], p.values[4]);
    return buf;
  }
  if (!p.entry) {
    char buf[300];
    std::snprintf(buf, sizeof buf,
                  "the paper's own parameters re-identified: sigma_long %.3g N/rpm (was %.3g), sigma_lat %.3g N/rpm "
                  "(was %.3g), D_x %.4g N/(m/s) (was %.4g), D_y %.4g N/(m/s) (was %.4g), D_psi %.3g N m/(rad/s) (was %.3g)",
                  p.values[0], base.terrain.sigma_long, p.values[1], base.terrain.sigma_lat, p.values[2],
                  base.terrain.D_x, p.values[3], base.terrain.D_y, p.values[4], base.terrain.D_psi);
    return buf;
  }
  if (p.texts.size() == 2 && !p.values.empty()) return TermForm(p.texts[0], p.texts[1]).describe(p.values[0]);
  return p.entry->describe ? p.entry->describe(p.values) : p.entry->doc;
}

FittedEffect fitted_effect(const Part& p, const Model& base, const std::vector<FitParam>& all, std::size_t& k) {
  FittedEffect fe;
  fe.effect = p.id;
  for (std::size_t i = 0; i < p.specs.size() && k < all.size(); ++i) fe.params.push_back(all[k++]);
  fe.description = describe(p, base);
  fe.held = p.free.empty();
  if (p.texts.size() == 2) fe.texts = {{"dof", p.texts[0]}, {"form", p.texts[1]}};
  return fe;
}

std::string tell_apart(const std::string& a, const std::string& b) {
  auto is = [&](const char* x, const char* y) { return (a == x && b == y) || (a == y && b == x); };
  auto any = [&](std::initializer_list<const char*> xs) {
    int n = 0;
    for (const char* x : xs) n += (a == x) + (b == x);
    return n == 2;
  };
  if (is("force_lag", "pose_time_offset"))
    return "steps of screw speed with the camera running: a force lag rounds the start of each motion, a "
           "time offset shifts starts and stops alike by the same time";
  if (any({"coulomb_friction", "stick_slip_friction", "screw_dead_band", "screw_blocking"}))
    return "slow moves with all screws at one low speed, then with one pair fast and one slow: a dead band "
           "depends on each screw's speed, dry friction on the body's motion, blocking on a screw standing "
           "still while the others push; a breakaway shows in starts from rest";
  if (is("imu_heading_bias", "imu_heading_drift"))
    return "a longer log or two logs minutes apart: a drift grows with time, a bias stays";
  if (any({kPaperParams, "quadratic_drag", "traction_saturation", kTerrainChange}))
    return "runs at constant 5, 10, 15, 20 rpm: linear drag gives speeds proportional to omega, quadratic drag "
           "and saturation flatten the fast end, a terrain change shows as a step in time";
  if (any({"terrain_slope", "resistance_offset"}))
    return "the same path driven at two headings: a slope depends on the heading, a resistance offset does not";
  if (any({"yaw_time_constant", "force_lag", "rigid_body_coupling"}))
    return "quick turns on the spot, then quick turns while driving forward: a yaw time constant shapes every "
           "turn, a force lag every start, the Coriolis coupling only turns made while moving";
  return "a log that excites both: vary speed, direction and heading";
}

std::vector<std::string> candidate_ids(const Dataset& d, const std::vector<std::string>& only) {
  std::vector<std::string> ids;
  for (const auto& le : effect_library()) {
    if (!only.empty() && std::find(only.begin(), only.end(), le.id) == only.end()) continue;
    if (le.needs_imu && !d.active[kImuPsi]) continue;
    if (d.gantry && (le.needs_imu || le.yaw_only)) continue;
    if (!d.gantry && !d.has_pose() && le.needs_pose) continue;
    ids.push_back(le.id);
  }
  return ids;
}


}  // namespace search
}  // namespace auger::wb
