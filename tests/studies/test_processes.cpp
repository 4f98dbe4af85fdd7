// studies::run_processes (demfem/studies/processes.hpp): child processes side by side, a task
// started once the tasks it waits for have succeeded (`run --jobs`: a run as soon as its own
// packing is made), and a task whose prerequisite failed not started at all.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "../scratch.hpp"
#include "demfem/studies/processes.hpp"

using namespace demfem;

namespace {
studies::ProcessTask sh(const std::string& script, const std::filesystem::path& log,
                        std::vector<std::size_t> after = {}) {
  return {{"/bin/sh", "-c", script}, log, 0.0, std::move(after)};
}
} // namespace

TEST(Processes, ATaskStartsWhenItsPrerequisitesSucceededAndNotAfterAFailure) {
  const auto dir = test::scratch("tasks");
  std::filesystem::create_directories(dir);
  const std::string a = (dir / "a_done").string();
  std::vector<studies::ProcessTask> tasks;
  tasks.push_back(sh("sleep 0.5; touch '" + a + "'", dir / "0.log")); // 0: a slow preparation
  tasks.push_back(sh("exit 3", dir / "1.log"));                       // 1: a failing one
  tasks.push_back(sh("exit 0", dir / "2.log", {1}));                  // 2: waits for 1
  tasks.push_back(sh("test -f '" + a + "'", dir / "3.log", {0}));     // 3: waits for 0
  // 4: needs nothing, so it takes the slot 1 leaves while 0 is still running (it would find
  // a_done if it had waited for every task before it)
  tasks.push_back(sh("test ! -f '" + a + "'", dir / "4.log"));
  tasks.push_back(sh("exit 0", dir / "5.log", {2})); // 5: waits for 2, which never starts
  std::vector<std::size_t> order;
  const auto res = studies::run_processes(
      tasks, 2, [&](std::size_t i, const studies::ProcessResult&) { order.push_back(i); });
  ASSERT_EQ(res.size(), tasks.size());
  EXPECT_EQ(res[0].exit_code, 0);
  EXPECT_EQ(res[1].exit_code, 3);
  EXPECT_FALSE(res[1].not_started);
  EXPECT_TRUE(res[2].not_started);
  EXPECT_EQ(res[2].exit_code, -1);
  EXPECT_EQ(res[3].exit_code, 0) << "started before its prerequisite had finished";
  EXPECT_FALSE(res[3].not_started);
  EXPECT_EQ(res[4].exit_code, 0) << "waited for a task it does not need";
  EXPECT_TRUE(res[5].not_started);
  EXPECT_EQ(order.size(), tasks.size()); // on_done once per task, started or not
  // a task that waits for a later one (not a list the callers build) is given up, not hung on
  std::vector<studies::ProcessTask> bad;
  bad.push_back(sh("exit 0", dir / "b0.log", {1}));
  bad.push_back(sh("exit 0", dir / "b1.log", {0}));
  const auto r2 = studies::run_processes(bad, 2);
  EXPECT_TRUE(r2[0].not_started);
  EXPECT_TRUE(r2[1].not_started);
}
