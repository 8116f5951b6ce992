// catkin_lint in make test: no error in CMakeLists.txt and package.xml (undeclared or unconfigured
// dependencies, undefined targets, ...). Its warnings and notices are listed by `catkin_lint -W2 .`;
// those left are justified in docs/architecture.md ("catkin_lint").
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "run_tool.h"
#include "test_files.h"

namespace mvod {
namespace {

TEST(PackageLintTest, CatkinLintFindsNoError) {
  // deps/debian-packages.txt installs it (make test's first step).
  ASSERT_TRUE(std::filesystem::exists("/usr/bin/catkin_lint"))
      << "catkin_lint is not installed: apt-get install catkin-lint (scripts/install_deps.sh)";
  const std::filesystem::path work = test::freshTestDir("mvod_lint");
  const test::RunResult run =
      test::runTool("/usr/bin/catkin_lint", {"-W0", MVOD_SOURCE_DIR}, work, {120, 0});
  EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_NE(run.err.find("found 0 problems"), std::string::npos) << run.out << run.err;
}

}  // namespace
}  // namespace mvod
