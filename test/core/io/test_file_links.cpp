// Files the node does not own are never touched (issue 48, item 5): a symbolic link at a map path
// is refused for writing, reading and resolving, naming the link and its target, and the target
// keeps its content, mode and name. Each case puts a decoy file (mode 0640) behind a link.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "multiview_object_detection/io/file_io.h"
#include "multiview_object_detection/io/map_path.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

constexpr char kDecoyText[] = "a file the node does not own\n";

class FileLinksTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::freshTestDir("mvod_file_links");
    fs::create_directories(dir_ / "maps");
    decoy_ = dir_ / "decoy.txt";
    std::ofstream(decoy_) << kDecoyText;
    fs::permissions(decoy_, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read,
                    fs::perm_options::replace);  // 0640
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The decoy as it was made: its content, its mode, and nothing beside it (no file moved aside).
  void expectDecoyUntouched() const {
    EXPECT_EQ(test::readText(decoy_), kDecoyText);
    struct stat info {};
    ASSERT_EQ(::lstat(decoy_.c_str(), &info), 0);
    EXPECT_TRUE(S_ISREG(info.st_mode));
    EXPECT_EQ(info.st_mode & 07777, 0640u);
    int beside = 0;
    for (const auto& entry : fs::directory_iterator(dir_)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("decoy", 0) == 0 || name.rfind(".decoy", 0) == 0) ++beside;
    }
    EXPECT_EQ(beside, 1) << "a file was moved or written beside the decoy";
  }

  fs::path dir_;
  fs::path decoy_;
};

TEST_F(FileLinksTest, AnAtomicWriteRefusesALinkAndLeavesItAndItsTargetAlone) {
  const fs::path link = dir_ / "maps" / "map.json";
  fs::create_symlink(decoy_, link);
  const Status written = writeFileAtomic(link.string(), "{\"objects\": []}");
  ASSERT_FALSE(written.ok()) << "wrote through (or replaced) a link";
  EXPECT_NE(written.message().find(link.string()), std::string::npos) << written.message();
  EXPECT_NE(written.message().find("symbolic link to " + decoy_.string()), std::string::npos)
      << written.message();
  EXPECT_TRUE(fs::is_symlink(link)) << "the link was replaced";
  EXPECT_EQ(fs::read_symlink(link), decoy_);
  expectDecoyUntouched();
  // No temporary left in the map folder.
  int entries = 0;
  for (const auto& entry : fs::directory_iterator(dir_ / "maps")) entries += entry.exists() ? 1 : 0;
  EXPECT_EQ(entries, 1);
}

TEST_F(FileLinksTest, AReplacedFileKeepsItsModeAndOwner) {
  const fs::path map = dir_ / "maps" / "map.json";
  ASSERT_TRUE(writeFileAtomic(map.string(), "first").ok());
  ASSERT_EQ(::chmod(map.c_str(), 0640), 0);
  // Root saves the file of another user (a node run as root, a map a user made): it stays theirs.
  if (::geteuid() == 0) {
    ASSERT_EQ(::chown(map.c_str(), 12345, 12345), 0);
  }
  struct stat before {};
  ASSERT_EQ(::stat(map.c_str(), &before), 0);
  ASSERT_TRUE(writeFileAtomic(map.string(), "second").ok());
  struct stat after {};
  ASSERT_EQ(::stat(map.c_str(), &after), 0);
  EXPECT_EQ(after.st_mode & 07777, 0640u);
  EXPECT_EQ(after.st_uid, before.st_uid);
  EXPECT_EQ(after.st_gid, before.st_gid);
  EXPECT_EQ(test::readText(map), "second");
}

TEST_F(FileLinksTest, ARefusingReadDoesNotFollowALinkAndAFollowingOneDoes) {
  const fs::path link = dir_ / "maps" / "map.json";
  fs::create_symlink(decoy_, link);
  std::string content = "untouched";
  const Status refused = readFile(link.string(), &content, kDefaultMaxFileBytes, Links::kRefuse);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("symbolic link to " + decoy_.string()), std::string::npos)
      << refused.message();
  EXPECT_EQ(content, "untouched");
  ASSERT_TRUE(readFile(link.string(), &content).ok());  // Links::kFollow, the default
  EXPECT_EQ(content, kDecoyText);
  expectDecoyUntouched();
}

TEST_F(FileLinksTest, AMapPathThatIsALinkIsRefusedInsideAndOutsideTheMapDirectory) {
  MapPathPolicy policy;
  policy.directory = (dir_ / "maps").string();
  // A link to another map inside the directory, and one to a file outside it.
  std::ofstream(dir_ / "maps" / "other.json") << "{}";
  fs::create_symlink(dir_ / "maps" / "other.json", dir_ / "maps" / "to_other.json");
  fs::create_symlink(decoy_, dir_ / "maps" / "to_decoy.json");
  for (const bool allow_any_path : {false, true}) {
    policy.allow_any_path = allow_any_path;
    for (const std::string name : {"to_other.json", "to_decoy.json"}) {
      for (const bool for_writing : {true, false}) {
        SCOPED_TRACE(name + (for_writing ? " for writing" : " for reading") +
                     (allow_any_path ? ", allow_any_map_path" : ""));
        std::string resolved = "unset";
        const Status status = resolveMapPath(name, policy, for_writing, &resolved);
        ASSERT_FALSE(status.ok()) << "resolved to " << resolved;
        EXPECT_NE(status.message().find(name), std::string::npos) << status.message();
        EXPECT_NE(status.message().find("symbolic link"), std::string::npos) << status.message();
        EXPECT_EQ(resolved, "unset");
      }
    }
  }
  // By its absolute path too.
  std::string resolved;
  const Status absolute =
      resolveMapPath((dir_ / "maps" / "to_decoy.json").string(), policy, true, &resolved);
  EXPECT_FALSE(absolute.ok());
  expectDecoyUntouched();
  EXPECT_EQ(test::readText(dir_ / "maps" / "other.json"), "{}");
}

TEST_F(FileLinksTest, LinksInTheFoldersAboveAMapAreResolvedAndStillChecked) {
  // A map directory reached through a link (~/.ros on another disk) is fine; a folder link inside
  // it that leads out is not.
  fs::create_directories(dir_ / "disk" / "maps");
  fs::create_symlink(dir_ / "disk", dir_ / "home");
  MapPathPolicy policy;
  policy.directory = (dir_ / "home" / "maps").string();
  std::string resolved;
  ASSERT_TRUE(resolveMapPath("kitchen.json", policy, true, &resolved).ok());
  EXPECT_EQ(resolved, (dir_ / "disk" / "maps" / "kitchen.json").string());
  fs::create_symlink(dir_, dir_ / "disk" / "maps" / "up");
  const Status out = resolveMapPath("up/decoy.txt", policy, true, &resolved);
  ASSERT_FALSE(out.ok());
  EXPECT_NE(out.message().find("outside map_directory"), std::string::npos) << out.message();
  expectDecoyUntouched();
}

}  // namespace
}  // namespace mvod
