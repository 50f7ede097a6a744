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

#include "fitting.hpp"

using namespace auger::wb::search;

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
