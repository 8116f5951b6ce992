// scripts/forget_moved_workspace.sh (issue 56, first hour): a `cp -a` copy of the checkout kept the
// build/ workspaces' CMake caches, which name the old folder, and `make build` stopped at "Configuring
// incomplete". A workspace made in another folder loses its build/ and devel/ (and says so); one made
// where it is keeps them.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "run_tool.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

const std::string kScript = std::string(MVOD_SOURCE_DIR) + "/scripts/forget_moved_workspace.sh";

// A workspace whose CMake cache says it was made in `made_in`.
void makeWorkspace(const fs::path& ws, const fs::path& made_in) {
  fs::create_directories(ws / "build");
  fs::create_directories(ws / "devel");
  fs::create_directories(ws / "src");
  std::ofstream(ws / "build" / "CMakeCache.txt")
      << "CMAKE_HOME_DIRECTORY:INTERNAL=" << (made_in / "src").string() << "\n"
      << "CMAKE_CACHEFILE_DIR:INTERNAL=" << (made_in / "build").string() << "\n";
}

TEST(ForgetMovedWorkspaceScriptTest, AWorkspaceMadeElsewhereIsBuiltAgainAndOneMadeHereIsKept) {
  const fs::path work = test::freshTestDir("mvod_forget_moved");
  const fs::path copied = work / "copy" / "build" / ".ws";
  const fs::path here = work / "here" / "build" / ".ws";
  makeWorkspace(copied, work / "original" / "build" / ".ws");
  makeWorkspace(here, here);
  const fs::path empty = work / "empty" / "build" / ".ws";  // never built: nothing to do
  test::RunResult run =
      test::runTool("bash", {kScript, copied.string(), here.string(), empty.string()}, work);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_FALSE(fs::exists(copied / "build"));
  EXPECT_FALSE(fs::exists(copied / "devel"));
  EXPECT_TRUE(fs::exists(copied / "src"));
  EXPECT_NE(run.out.find(copied.string() + " was made in " +
                         (work / "original" / "build" / ".ws").string()),
            std::string::npos)
      << run.out;
  EXPECT_TRUE(fs::exists(here / "build" / "CMakeCache.txt"));
  EXPECT_TRUE(fs::exists(here / "devel"));
  EXPECT_EQ(run.out.find(here.string() + " was made"), std::string::npos) << run.out;
  fs::remove_all(work);
}

}  // namespace
}  // namespace mvod
