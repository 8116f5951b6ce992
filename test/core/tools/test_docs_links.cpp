// The docs check (scripts/check_docs.py) in make test: every relative link of the package's
// Markdown names a file and heading that exist, and every README heading a script names is there.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "run_tool.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

const std::string kChecker = std::string(MVOD_SOURCE_DIR) + "/scripts/check_docs.py";

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

TEST(DocsLinksTest, EveryLinkAndHeadingOfThePackageResolves) {
  const fs::path work = test::freshTestDir("mvod_docs");
  const test::RunResult run =
      test::runTool("/usr/bin/python3", {kChecker, MVOD_SOURCE_DIR}, work, {60, 0});
  EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_NE(run.out.find(" 0 broken references"), std::string::npos) << run.out << run.err;
}

// The check finds what it is for: a missing file, a missing heading, a script's stale "see README".
TEST(DocsLinksTest, BrokenLinksAndStaleHeadingsAreFound) {
  const fs::path root = test::freshTestDir("mvod_docs_broken");
  write(root / "README.md",
        "# Package\n\n## Quick start\n\nSee [the docs](docs/guide.md#setting-up), "
        "[missing](docs/missing.md), [here](#quick-start) and [gone](#evaluation).\n");
  write(root / "docs" / "guide.md",
        "# Guide\n\n## Setting up\n\n[back](../README.md#quick-start)\n"
        "[wrong](../README.md#install)\n");
  write(root / "scripts" / "demo.sh",
        "echo 'see README, Evaluation'\necho 'see README, Quick start'\n");
  const test::RunResult run =
      test::runTool("/usr/bin/python3", {kChecker, root.string()}, root, {60, 0});
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(run.out.find("README.md:5: link to docs/missing.md: no such file"), std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("README.md:5: link to #evaluation: no heading"), std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("docs/guide.md:6: link to ../README.md#install: no heading"),
            std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("scripts/demo.sh:1: README has no heading \"Evaluation\""),
            std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("4 broken references"), std::string::npos) << run.out;
}

}  // namespace
}  // namespace mvod
