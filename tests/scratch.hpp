// A private scratch directory for each test, so that test programs running at the same time (ctest
// -j, two checkouts, a sanitizer build beside the normal one) never share a path:
//
//   <temp>/demfem_<Suite>.<Test>_<pid>/<name>
//
// (<temp> is std::filesystem::temp_directory_path(), i.e. $TMPDIR or /tmp). The per-test directory
// is removed when the test passes and kept, for inspection, when it fails. Outside a test body
// (e.g. a static initializer) the directory is named after the program's pid alone and removed at
// program end when every test passed.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <mutex>
#include <set>
#include <string>
#include <system_error>
#include <unistd.h>

namespace demfem::test {

namespace detail {

// Removes the per-test directory of each test that passed.
class ScratchCleaner : public ::testing::EmptyTestEventListener {
public:
  explicit ScratchCleaner(std::filesystem::path (*root)(const ::testing::TestInfo*))
      : root_(root) {}
  void OnTestEnd(const ::testing::TestInfo& info) override {
    if (!info.result()->Passed()) return;
    std::error_code ec;
    std::filesystem::remove_all(root_(&info), ec);
  }
  void OnTestProgramEnd(const ::testing::UnitTest& unit) override {
    if (!unit.Passed()) return;
    std::error_code ec;
    std::filesystem::remove_all(root_(nullptr), ec);
  }

private:
  std::filesystem::path (*root_)(const ::testing::TestInfo*);
};

inline std::filesystem::path scratch_root(const ::testing::TestInfo* info) {
  std::string tag = "demfem_";
  if (info != nullptr)
    tag += std::string(info->test_suite_name()) + "." + info->name();
  else
    tag += "program";
  // Parameterized and typed tests carry '/' in their names.
  std::replace_if(
      tag.begin(), tag.end(), [](char c) { return c == '/' || c == ' ' || c == ':'; }, '_');
  return std::filesystem::temp_directory_path() / (tag + "_" + std::to_string(::getpid()));
}

inline void register_cleaner() {
  static std::once_flag once;
  std::call_once(once, [] {
    ::testing::UnitTest::GetInstance()->listeners().Append(new ScratchCleaner(&scratch_root));
  });
}

} // namespace detail

// This test's scratch directory (created), or `name` inside it. A named entry is removed first
// (a fresh path, not created: callers create a file or directory there as they need); its parent
// exists.
inline std::filesystem::path scratch(const std::string& name = "") {
  detail::register_cleaner();
  const auto root = detail::scratch_root(::testing::UnitTest::GetInstance()->current_test_info());
  std::filesystem::create_directories(root);
  if (name.empty()) return root;
  const auto p = root / name;
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p.parent_path());
  return p;
}

// scratch(name), created as an (empty) directory.
inline std::filesystem::path scratch_dir(const std::string& name) {
  const auto p = scratch(name);
  std::filesystem::create_directories(p);
  return p;
}

} // namespace demfem::test
