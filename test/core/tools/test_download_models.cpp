// scripts/download_models.sh in the first hour (issue 56): --help prints its own usage (it made a
// folder named --help and printed mkdir's), an unknown option is refused, and without a network it
// says which file it could not get, from where and where to copy it (it ended in curl's raw error).
// No network is needed: the downloads go through a proxy that refuses every connection.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "run_tool.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

const std::string kScript = std::string(MVOD_SOURCE_DIR) + "/scripts/download_models.sh";

TEST(DownloadModelsScriptTest, HelpBadOptionsAndNoNetworkSayWhatToDo) {
  const fs::path work = test::freshTestDir("mvod_download_models");
  test::RunLimits limits;
  limits.timeout_s = 120;
  test::RunResult help = test::runTool("bash", {kScript, "--help"}, work, limits);
  EXPECT_EQ(help.exit_code, 0) << help.err;
  EXPECT_NE(help.out.find("Usage: download_models.sh [DIR]"), std::string::npos) << help.out;
  EXPECT_FALSE(fs::exists(work / "--help"));
  EXPECT_FALSE(fs::exists(fs::current_path() / "--help"));

  test::RunResult bad = test::runTool("bash", {kScript, "--force"}, work, limits);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("unknown option '--force'"), std::string::npos) << bad.err;

  const fs::path models = work / "models";
  test::RunResult offline =
      test::runTool("env",
                    {"http_proxy=http://127.0.0.1:9", "https_proxy=http://127.0.0.1:9",
                     "HTTP_PROXY=http://127.0.0.1:9", "HTTPS_PROXY=http://127.0.0.1:9",
                     "no_proxy=", "bash", kScript, models.string()},
                    work, limits);
  EXPECT_EQ(offline.exit_code, 1) << offline.out << offline.err;
  EXPECT_NE(offline.err.find("could not download FastestDet.onnx"), std::string::npos)
      << offline.err;
  EXPECT_NE(offline.err.find("Copy it by hand from https://"), std::string::npos) << offline.err;
  EXPECT_FALSE(fs::exists(models / "FastestDet.onnx.part"));
  fs::remove_all(work);
}

}  // namespace
}  // namespace mvod
