// augerd's sockets under load (docs/daemon.md "Limits and abuse"): `stop` answered behind 32
// active clients and a queue (issue 28), the loop held while both sockets are abused (issue 13).
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "auger/log.hpp"
#include "daemon_kit.hpp"

using namespace daemon_kit;

namespace {

// A client that keeps one connection and sends `line` every period (a teleop, a monitor).
struct Keeper {
  std::atomic<bool> run{true};
  std::atomic<int> answers{0}, errors{0};
  std::thread t;
  Keeper(const std::string& sock, const std::string& line, double period_s) {
    t = std::thread([=] {
      const int fd = connect_to(sock);
      if (fd < 0) return;
      std::string in;
      char buf[8192];
      while (run) {
        send(fd, (line + "\n").data(), line.size() + 1, MSG_NOSIGNAL);
        const double until = SimRig::wall_s() + period_s;
        while (SimRig::wall_s() < until) {
          pollfd p{fd, POLLIN, 0};
          if (poll(&p, 1, 10) <= 0) continue;
          const ssize_t n = recv(fd, buf, sizeof buf, 0);
          if (n <= 0) break;
          in.append(buf, std::size_t(n));
          for (std::size_t nl; (nl = in.find('\n')) != std::string::npos; in.erase(0, nl + 1))
            (in.rfind("error", 0) == 0 ? errors : answers)++;
        }
      }
      close(fd);
    });
  }
  ~Keeper() {
    run = false;
    t.join();
  }
};

// Loop period statistics of the log rows with t_s in [t0, t1).
struct Period {
  int n = 0;
  double mean_s = 0, std_s = 0, max_dev_s = 0, max_s = 0;
};
Period log_period(const std::string& log_dir, double t0, double t1) {
  Period p;
  double sum = 0, sum2 = 0;
  for (const std::string& path : csv_logs(log_dir)) {
    auger::RobotLogReader r(path);
    auger::RobotSample s;
    while (r.next(s)) {
      if (s.t_s < t0 || s.t_s >= t1 || !std::isfinite(s.loop_dt_s)) continue;
      ++p.n;
      sum += s.loop_dt_s;
      sum2 += s.loop_dt_s * s.loop_dt_s;
      p.max_dev_s = std::max(p.max_dev_s, std::fabs(s.loop_dt_s - 0.01));
      p.max_s = std::max(p.max_s, s.loop_dt_s);
    }
  }
  if (p.n) p.mean_s = sum / p.n, p.std_s = std::sqrt(std::max(0.0, sum2 / p.n - p.mean_s * p.mean_s));
  return p;
}

// augerd's report at exit of its cycles' own work (docs/daemon.md): the longest in wall time and
// in the loop thread's CPU time and the mean CPU time, in ms, the cycles whose CPU time exceeded
// the period, and the number of cycles; -1 when a line is missing.
struct Work {
  double wall_ms = -1, cpu_ms = -1, mean_cpu_ms = -1;
  long over = -1, cycles = -1;
};
Work cycle_work(const std::string& err) {
  Work w;
  const auto b = err.rfind("cycle work: longest ");
  if (b != std::string::npos)
    std::sscanf(err.c_str() + b, "cycle work: longest %lf ms wall, %lf ms CPU; mean %lf ms CPU; %ld cycles over",
                &w.wall_ms, &w.cpu_ms, &w.mean_cpu_ms, &w.over);
  const auto c = err.rfind("augerd: ", err.find(" cycles; loop period"));
  if (c != std::string::npos) std::sscanf(err.c_str() + c, "augerd: %ld cycles;", &w.cycles);
  return w;
}

// The loop's checks under load. Without SCHED_FIFO (CI, a shared workstation) the loop can be
// preempted, by the test's own clients among others, and a period stretched by that says
// nothing of augerd; its own CPU time per cycle does. So: the CPU work of the cycles fits in
// their period (the largest work is taking a cycle's connections from four clients reconnecting flat
// out: docs/daemon.md), and no period, however preempted, comes near the modules' 100
// ms no-telemetry timeout (the line past which something would happen to the robot). One cycle
// in a hundred may overrun in CPU time: on a 2-core virtual machine shared with other tests, one
// cycle of the stop test once took 12.7 ms of CPU time (the host's preemption of the virtual
// CPU, and caches shared with the other tests, are counted in it), while the same binary alone
// stayed under 10 ms; the mean and the overruns' count are what says the loop keeps up.
void check_loop(const Period& per, const Work& work) {
  INFO("cycle work: longest " << work.cpu_ms << " ms CPU, mean " << work.mean_cpu_ms << " ms CPU, " << work.over
                              << " of " << work.cycles << " cycles over the period");
  REQUIRE(work.cycles > 0);
  REQUIRE(work.over >= 0);
  CHECK(work.mean_cpu_ms < 5.0);
  CHECK(work.over <= std::max(1L, work.cycles / 100));
  CHECK(work.cpu_ms < 40.0);
  CHECK(per.max_s < 0.08);
  if (per.max_s >= 0.05)
    WARN("a period of " << per.max_s * 1e3 << " ms with at most " << work.cpu_ms
                        << " ms of the loop's own CPU time per cycle: the machine preempted augerd");
}

// `stop` on a fresh connection, timed from the send to the answer "ok"; 1e9 when no "ok" came
// within a second.
double timed_stop_ms(const std::string& cmd) {
  const int fd = connect_to(cmd);
  if (fd < 0) return 1e9;
  const double t0 = SimRig::wall_s();
  send(fd, "stop\n", 5, MSG_NOSIGNAL);
  std::string got;
  char buf[256];
  pollfd p{fd, POLLIN, 0};
  while (got.find('\n') == std::string::npos && poll(&p, 1, 1000) > 0) {
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.append(buf, std::size_t(n));
  }
  close(fd);
  return got == "ok\n" ? 1e3 * (SimRig::wall_s() - t0) : 1e9;
}

// The load test (issue 13): augerd drives the robot (vel, kept alive on one connection) while its
// sockets are abused the ways that froze it before, all at once, for duration_s: more idle
// connections than the cap on both sockets, clients flooding `status all` (some never reading
// their answers), a stream of short connections, follow of a FIFO, of /dev/zero, of a file too
// big and of one with too many rows, garbage and absurd values on the sensors socket. Then
// `stop` on fresh connections, timed. Bounded: loopback Unix sockets only, a fixed duration.
void abuse(double duration_s) {
  Run r("load");
  const std::string &dir = r.dir, &cmd = r.cmd, &sens = r.sens;
  SimRig& rig = r.rig;
  Daemon& d = *r.d;
  REQUIRE(talk(cmd, "enable\n", 1) == "ok");
  Keeper feeder(cmd, "vel 0.03 0 0", 0.1);
  REQUIRE(wait_until([&] { return all_driven(rig); }, 2.0));
  sleep_s(1.0);
  const double t_abuse0 = status_value(talk(cmd, "status\n", 1), "t_s");

  std::atomic<bool> run{true};
  std::vector<std::thread> threads;
  std::vector<int> idle;
  std::atomic<long> flood_answers{0}, short_answers{0}, short_tries{0}, follow_errors{0}, sensor_lines{0};
  // Flooders: 20 000 `status all` each, as fast as the socket takes them; two read, two never do.
  for (int k = 0; k < 4; ++k)
    threads.emplace_back([&, k] {
      const int fd = connect_to(cmd);
      std::string many;
      for (int i = 0; i < 1000; ++i) many += "status all\n";
      char buf[65536];
      for (int rep = 0; rep < 20 && run; ++rep) {
        std::size_t off = 0;
        while (off < many.size() && run) {
          pollfd p{fd, short(POLLOUT | (k < 2 ? POLLIN : 0)), 0};
          if (poll(&p, 1, 20) <= 0) continue;
          if (p.revents & POLLIN) {
            const ssize_t n = recv(fd, buf, sizeof buf, 0);
            if (n <= 0) break;
            flood_answers += std::count(buf, buf + n, '\n');
          }
          if (p.revents & POLLOUT) {
            const ssize_t n = send(fd, many.data() + off, many.size() - off, MSG_NOSIGNAL | MSG_DONTWAIT);
            if (n > 0) off += std::size_t(n);
            else if (n < 0 && errno != EAGAIN) break;
          }
          if (p.revents & (POLLHUP | POLLERR)) break;
        }
      }
      while (run) sleep_s(0.05);
      close(fd);
    });
  // More idle connections than the cap, on both sockets.
  for (int k = 0; k < 40; ++k) idle.push_back(connect_to(cmd));
  for (int k = 0; k < 40; ++k) idle.push_back(connect_to(sens));
  // A stream of short connections, at most 300 a second.
  threads.emplace_back([&] {
    while (run) {
      ++short_tries;
      if (talk(cmd, "status\n", 1).rfind("status t_s=", 0) == 0) ++short_answers;
      sleep_s(1.0 / 300);
    }
  });
  // follow of files that froze or bloated the loop before, twice a second.
  const std::string fifo = dir + "/fifo", big = dir + "/big.csv", many = dir + "/many.csv";
  REQUIRE(mkfifo(fifo.c_str(), 0600) == 0);
  {
    const int fd = open(big.c_str(), O_WRONLY | O_CREAT, 0644);
    REQUIRE(ftruncate(fd, off_t(1) << 30) == 0);  // 1 GiB, sparse
    close(fd);
    std::ofstream f(many);
    f << "t_s,x_m,y_m,psi_rad\n";
    for (int i = 0; i <= 100000; ++i) f << i << ",0,0,0\n";
  }
  threads.emplace_back([&] {
    const std::string paths[] = {fifo, "/dev/zero", big, many};
    for (int i = 0; run; ++i) {
      const std::string a = talk(cmd, "follow " + paths[i % 4] + "\n", 1);
      if (a.rfind("error: ", 0) == 0) ++follow_errors;
      sleep_s(0.5);
    }
  });
  // The sensors socket: garbage, control bytes and absurd values, as fast as it takes them.
  for (int k = 0; k < 2; ++k)
    threads.emplace_back([&] {
      const int fd = connect_to(sens);
      const std::string t = now_unix();
      std::string junk = "imu " + t + " 0 1e100\npose " + t + " 0 0 0 1e300 1e300 1e300\nimu " + t +
                         " 0 1e20\ngarbage \x01\x02\x7f\n" + std::string("imu 1\0 0 0\n", 11) + "vel 1 2 3\n";
      while (run) {
        pollfd p{fd, POLLOUT, 0};
        if (poll(&p, 1, 20) <= 0) continue;
        const ssize_t n = send(fd, junk.data(), junk.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0 && errno != EAGAIN) break;
        if (n > 0) sensor_lines += 6;
        char buf[65536];
        while (recv(fd, buf, sizeof buf, MSG_DONTWAIT) > 0) {
        }
      }
      close(fd);
    });

  sleep_s(duration_s);
  // Still under abuse: no module timed out, the robot is driven, the dead-man fed.
  const std::string st = talk(cmd, "status\n", 1);
  const std::string err_text = d.stderr_text();
  const bool driven = all_driven(rig);
  // `stop` on fresh connections, timed from the send to the answer, each followed by enable.
  std::vector<double> stop_ms;
  for (int k = 0; k < 10; ++k) {
    stop_ms.push_back(timed_stop_ms(cmd));
    CHECK(stop_ms.back() < 1e9);
    sleep_s(0.05);
    talk(cmd, "enable\n", 1);
    sleep_s(0.1);
  }
  const double t_abuse1 = status_value(talk(cmd, "status\n", 1), "t_s");
  run = false;
  for (auto& t : threads) t.join();
  for (int fd : idle) close(fd);
  kill(d.pid, SIGTERM);
  CHECK(d.wait_exit(3.0) == 0);
  // augerd's own report at exit: its loop period and the log's syncs (docs/daemon.md).
  std::string report;
  for (const char* key : {"augerd: log:", "cycles; loop period", "cycle work:"}) {
    const std::string all = d.stderr_text();
    auto b = all.rfind(key);
    if (b == std::string::npos) continue;
    b = all.rfind('\n', b) == std::string::npos ? 0 : all.rfind('\n', b) + 1;  // the whole line
    report += "\n  " + all.substr(b, all.find('\n', b) - b);
  }

  const Period per = log_period(dir + "/log", t_abuse0, t_abuse1);
  std::sort(stop_ms.begin(), stop_ms.end());
  WARN("load test, " << duration_s << " s of abuse: loop period mean " << per.mean_s * 1e3 << " ms, std "
                     << per.std_s * 1e3 << " ms, longest " << per.max_s * 1e3 << " ms (" << per.n
                     << " cycles); stop answered in " << stop_ms.front() << " / " << stop_ms[stop_ms.size() / 2]
                     << " / " << stop_ms.back() << " ms (min / median / max of " << stop_ms.size()
                     << "); flood answers " << flood_answers << ", short connections answered " << short_answers
                     << " of " << short_tries << ", follow refused " << follow_errors << ", sensor lines sent "
                     << sensor_lines << report);
  INFO(st << "\n" << err_text);
  CHECK(st.find("fault=none") != std::string::npos);
  CHECK(st.find("mode=vel") != std::string::npos);
  CHECK(driven);
  CHECK(err_text.find("no-telemetry") == std::string::npos);
  CHECK(err_text.find("corrupt-frames") == std::string::npos);
  CHECK(per.n > int(80 * duration_s));
  check_loop(per, cycle_work(d.stderr_text()));
  CHECK(per.std_s < 0.003);
  CHECK(short_answers > 0.9 * short_tries);
  CHECK(follow_errors > 0);
  // Within one cycle: the line waits at most a period for the next cycle, plus the machine's
  // scheduling (two cores shared with builds); the median must show the one cycle.
  CHECK(stop_ms[stop_ms.size() / 2] < 15.0);
  CHECK(stop_ms.back() < 40.0);
}

// `stop` behind a full house (issue 28 point 3): 32 clients that stay active (one keeps `vel`
// alive, 31 send `status` every 20 ms, so none is ever idle long enough to give way), 100
// connections queued behind them that send nothing, 100 that send `vel` (no slot will free for
// them), and four clients reconnecting as fast as they can to keep the queue full. `stop` on
// fresh connections must be answered within 20 ms (two cycles), and must stop every screw.
void stop_behind_queue() {
  Run r("stopq");
  const std::string &dir = r.dir, &cmd = r.cmd;
  SimRig& rig = r.rig;
  Daemon& d = *r.d;
  INFO(d.stderr_text());
  REQUIRE(talk(cmd, "enable\n", 1) == "ok");
  Keeper feeder(cmd, "vel 0.03 0 0", 0.1);
  REQUIRE(wait_until([&] { return all_driven(rig); }, 2.0));
  std::vector<std::unique_ptr<Keeper>> active;
  for (int k = 0; k < 31; ++k) active.push_back(std::make_unique<Keeper>(cmd, "status", 0.02));
  sleep_s(0.3);
  const double t0 = status_value(talk(cmd, "status\n", 1), "t_s");
  std::vector<int> queued;
  for (int k = 0; k < 200; ++k) {
    const int fd = connect_to(cmd);
    if (fd >= 0 && k % 2) send(fd, "vel 0.1 0 0\n", 12, MSG_NOSIGNAL);
    queued.push_back(fd);
  }
  std::atomic<bool> run{true};
  std::atomic<long> reconnects{0};
  std::vector<std::thread> threads;
  for (int k = 0; k < 4; ++k)
    threads.emplace_back([&] {
      while (run) {
        const int fd = connect_to(cmd);
        if (fd >= 0) close(fd);
        ++reconnects;
      }
    });
  sleep_s(1.0);
  const bool driven = all_driven(rig);
  std::vector<double> stop_ms;
  bool stopped = false;
  for (int k = 0; k < 10; ++k) {
    stop_ms.push_back(timed_stop_ms(cmd));
    if (k == 0) stopped = wait_until([&] { return all_stopped(rig); }, 0.2);
    sleep_s(0.05);
  }
  const std::string st = talk(cmd, "status\n", 1);
  const double t1 = status_value(st, "t_s");
  run = false;
  for (auto& t : threads) t.join();
  long active_errors = 0;
  for (auto& a : active) active_errors += a->errors;
  active.clear();
  for (int fd : queued)
    if (fd >= 0) close(fd);
  kill(d.pid, SIGTERM);
  CHECK(d.wait_exit(3.0) == 0);
  const Period per = log_period(dir + "/log", t0, t1);
  const Work work = cycle_work(d.stderr_text());
  std::sort(stop_ms.begin(), stop_ms.end());
  WARN("stop behind 32 active clients and a queue (" << reconnects << " reconnections): stop answered in "
                                                      << stop_ms.front() << " / " << stop_ms[stop_ms.size() / 2]
                                                      << " / " << stop_ms.back()
                                                      << " ms (min / median / max of 10); loop period mean "
                                                      << per.mean_s * 1e3 << " ms, longest " << per.max_s * 1e3
                                                      << " ms (" << per.n << " cycles); longest cycle work "
                                                      << work.cpu_ms << " ms CPU, " << work.wall_ms << " ms wall");
  INFO(st << "\n" << d.stderr_text());
  CHECK(driven);
  CHECK(stopped);
  CHECK(st.find("mode=stopped") != std::string::npos);
  CHECK(stop_ms.back() <= 20.0);
  check_loop(per, work);
  CHECK(active_errors == 0);
}

}  // namespace

TEST_CASE("stop is answered within two cycles behind 32 active clients and a queue", "[load]") {
  stop_behind_queue();
}

TEST_CASE("augerd holds its loop while its sockets are abused", "[load]") { abuse(4.0); }

// make test-full: the same for a minute.
TEST_CASE("augerd holds its loop while its sockets are abused, one minute", "[.load_full]") { abuse(60.0); }

