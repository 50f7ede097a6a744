// The search's threads (fitting.hpp): a worker of run_parallel with no task left helps with the
// loop another task offers (share_loop), every item runs exactly once, and an item's exception
// reaches the loop's owner without leaving the loop on offer.
#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>

#include "engine_synth.hpp"
#include "fitting.hpp"

using namespace auger;
using namespace auger::wb;
using namespace auger::wb::search;
using namespace auger::wb::test;

namespace {

// Task 0 offers a loop of slow items; task 1 is empty, so its worker is idle at once.
struct Run {
  std::vector<int> count = std::vector<int>(24, 0);
  std::set<std::thread::id> runners;
  std::mutex m;
};

void offer_slow_loop(Run& run, int threads) {
  run_parallel(threads, {0, 1}, [](std::size_t) { return -1; }, [&](std::size_t task) {
    if (task != 0) return;
    share_loop(run.count.size(), [&](std::size_t i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      std::lock_guard<std::mutex> lock(run.m);
      ++run.count[i];
      run.runners.insert(std::this_thread::get_id());
    });
  });
}

}  // namespace

TEST_CASE("share_loop: the idle worker helps, every item once") {
  Run two;
  offer_slow_loop(two, 2);
  for (int c : two.count) CHECK(c == 1);
  // 24 items of 10 ms: the other worker, idle after its empty task, takes some of them.
  CHECK(two.runners.size() == 2);

  Run one;
  offer_slow_loop(one, 1);
  for (int c : one.count) CHECK(c == 1);
  CHECK(one.runners.size() == 1);  // --threads 1: explain stays on one thread

  // Outside run_parallel (auger fit) the caller runs every item.
  std::vector<int> alone(5, 0);
  share_loop(alone.size(), [&](std::size_t i) { ++alone[i]; });
  for (int c : alone) CHECK(c == 1);
}

TEST_CASE("share_loop: an item's exception reaches the owner; the next loop runs normally") {
  std::atomic<int> ran{0};
  std::string caught;
  // Whichever thread runs item 3 (the owner or the helper), the owner gets its exception.
  run_parallel(2, {0, 1}, [](std::size_t) { return -1; }, [&](std::size_t task) {
    if (task != 0) return;
    try {
      share_loop(50, [&](std::size_t i) {
        ++ran;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        if (i == 3) throw std::runtime_error("item 3 failed");
      });
    } catch (const std::runtime_error& e) {
      caught = e.what();
    }
  });
  CHECK(caught == "item 3 failed");
  CHECK(ran < 50);  // the items after the failure are skipped
  Run after;
  offer_slow_loop(after, 2);
  for (int c : after.count) CHECK(c == 1);
  CHECK(after.runners.size() == 2);
}

TEST_CASE("run_parallel: a task's exception reaches the caller, whichever thread ran it") {
  for (std::size_t thrower = 0; thrower < 4; ++thrower) {
    std::atomic<int> ran{0};
    CHECK_THROWS_WITH(run_parallel(2, {0, 1, 2, 3}, [](std::size_t) { return -1; },
                                   [&](std::size_t task) {
                                     ++ran;
                                     std::this_thread::sleep_for(std::chrono::milliseconds(5));
                                     if (task == thrower) throw std::invalid_argument("task failed");
                                   }),
                      "task failed");
    CHECK(ran >= 1);
  }
}

TEST_CASE("fit: the same answer on one thread and on two") {
  SynthOptions o;
  o.seconds = 40;
  const Model truth = make_model(RobotParams{}, kSand, {entry("coulomb_friction").make({8, 6, 1})});
  const Dataset d = synth(truth, o);
  const FitResult one = fit(d, nominal(), {"coulomb_friction"}, false, {}, {}, 1);
  const FitResult two = fit(d, nominal(), {"coulomb_friction"}, false, {}, {}, 2);
  CHECK(one.model_toml == two.model_toml);
  for (std::size_t c = 0; c < one.err_after.rms.size(); ++c) CHECK(one.err_after.rms[c] == two.err_after.rms[c]);
  CHECK(one.err_after.ratio_to_noise[0] < 1.3);  // (and it is a fit: the friction found)
}
