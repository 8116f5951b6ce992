// COCO class names and the class priors YAML (sizes for Eq. 9, fusion distances for Eq. 6),
// including the package's own config/class_priors.yaml.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/pipeline/map/refinement.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

std::string configPath() { return std::string(MVOD_SOURCE_DIR) + "/config/class_priors.yaml"; }

// The classes the package's priors file must give a size for.
const std::vector<std::string> kRequiredClasses = {
    "chair",    "couch", "bed",       "dining table", "toilet",   "tv",    "laptop", "refrigerator",
    "oven",     "sink",  "microwave", "book",         "bottle",   "cup",   "bowl",   "potted plant",
    "keyboard", "mouse", "backpack",  "handbag",      "suitcase", "clock", "vase",   "person"};

TEST(CocoClassNamesTest, EightyNamesInTheContiguousOrder) {
  const std::vector<std::string>& names = cocoClassNames();
  ASSERT_EQ(names.size(), 80u);
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()).size(), 80u);
  EXPECT_EQ(names[0], "person");
  EXPECT_EQ(names[39], "bottle");
  EXPECT_EQ(names[41], "cup");
  EXPECT_EQ(names[56], "chair");
  EXPECT_EQ(names[57], "couch");
  EXPECT_EQ(names[58], "potted plant");
  EXPECT_EQ(names[60], "dining table");
  EXPECT_EQ(names[62], "tv");
  EXPECT_EQ(names[73], "book");
  EXPECT_EQ(names[79], "toothbrush");
  for (size_t i = 0; i < names.size(); ++i) {
    EXPECT_EQ(cocoClassId(names[i]), static_cast<int>(i)) << names[i];
  }
}

TEST(CocoClassNamesTest, DarknetSpellingsAndUnknownNames) {
  EXPECT_EQ(cocoClassId("diningtable"), cocoClassId("dining table"));
  EXPECT_EQ(cocoClassId("sofa"), cocoClassId("couch"));
  EXPECT_EQ(cocoClassId("tvmonitor"), cocoClassId("tv"));
  EXPECT_EQ(cocoClassId("pottedplant"), cocoClassId("potted plant"));
  EXPECT_EQ(cocoClassId("motorbike"), cocoClassId("motorcycle"));
  EXPECT_EQ(cocoClassId("aeroplane"), cocoClassId("airplane"));
  EXPECT_EQ(cocoClassId(""), -1);
  EXPECT_EQ(cocoClassId("table"), -1);
  EXPECT_EQ(cocoClassId("Chair"), -1);
}

// FastestDet's label file (darknet spellings): line i must name class id i.
TEST(CocoClassNamesTest, MatchesFastestDetLabelFileWhenPresent) {
  const fs::path labels = fs::path(MVOD_SOURCE_DIR) / ".." / "shared" / "models" / "coco.names";
  std::ifstream in(labels);
  if (!in) GTEST_SKIP() << labels << " not found";
  std::string line;
  int index = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    EXPECT_EQ(cocoClassId(line), index) << line;
    ++index;
  }
  EXPECT_EQ(index, 80);
}

// A ClassPriors with recognisable content, to see that failed parses leave it alone.
ClassPriors sentinel() {
  ClassPriors priors;
  priors.default_fusion_distance_m = 1.23;
  ClassPrior bed;
  bed.class_name = "bed";
  bed.has_size = true;
  bed.size_m = Eigen::Vector3d(2, 1.6, 0.6);
  bed.fusion_distance_m = 0.9;
  priors.set(bed);
  return priors;
}

void expectSentinel(const ClassPriors& priors) {
  EXPECT_EQ(priors.default_fusion_distance_m, 1.23);
  ASSERT_EQ(priors.all().size(), 1u);
  ASSERT_NE(priors.find("bed"), nullptr);
  EXPECT_EQ(priors.find("bed")->fusion_distance_m, 0.9);
}

TEST(ClassPriorsTest, ParsesSizesDistancesAndDefaults) {
  ClassPriors priors = sentinel();
  const Status status = ClassPriors::parseYaml(
      "classes:\n"
      "  chair: {size_m: [0.55, 0.55, 0.9], fusion_distance_m: 0.4}\n"
      "  cup: {fusion_distance_m: 0.1}\n"
      "  book:\n"
      "    size_m: [0.23, 0.16, 0.03]\n"
      "  diningtable: {size_m: [1.5, 0.9, 0.75]}\n"
      "  vase:\n"
      "default_fusion_distance_m: 0.7\n",  // written after the classes, still their default
      &priors);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(priors.default_fusion_distance_m, 0.7);
  EXPECT_EQ(priors.all().size(), 5u);
  EXPECT_EQ(priors.find("bed"), nullptr) << "the old content is replaced";

  const ClassPrior* chair = priors.find("chair");
  ASSERT_NE(chair, nullptr);
  EXPECT_EQ(chair->class_name, "chair");
  EXPECT_TRUE(chair->has_size);
  EXPECT_EQ(chair->size_m, Eigen::Vector3d(0.55, 0.55, 0.9));
  EXPECT_EQ(chair->fusion_distance_m, 0.4);

  const ClassPrior* cup = priors.find("cup");
  ASSERT_NE(cup, nullptr);
  EXPECT_FALSE(cup->has_size);
  EXPECT_EQ(cup->fusion_distance_m, 0.1);

  const ClassPrior* book = priors.find("book");
  ASSERT_NE(book, nullptr);
  EXPECT_TRUE(book->has_size);
  EXPECT_EQ(book->fusion_distance_m, 0.7);

  const ClassPrior* vase = priors.find("vase");
  ASSERT_NE(vase, nullptr);
  EXPECT_FALSE(vase->has_size);
  EXPECT_EQ(vase->fusion_distance_m, 0.7);

  // The darknet spelling is stored under the COCO name and found under either.
  ASSERT_NE(priors.find("dining table"), nullptr);
  EXPECT_EQ(priors.find("dining table")->class_name, "dining table");
  EXPECT_EQ(priors.find("diningtable"), priors.find("dining table"));

  EXPECT_EQ(priors.fusionDistance("chair"), 0.4);
  EXPECT_EQ(priors.fusionDistance("book"), 0.7);
  EXPECT_EQ(priors.fusionDistance("person"), 0.7);  // not listed: the default
  EXPECT_EQ(priors.find("person"), nullptr);
}

TEST(ClassPriorsTest, DefaultsWhenKeysAreMissing) {
  ClassPriors priors = sentinel();
  ASSERT_TRUE(ClassPriors::parseYaml("classes: {cup: {fusion_distance_m: 0.1}}", &priors).ok());
  EXPECT_EQ(priors.default_fusion_distance_m, ClassPriors().default_fusion_distance_m);
  EXPECT_EQ(priors.all().size(), 1u);

  ASSERT_TRUE(ClassPriors::parseYaml("default_fusion_distance_m: 0.3\n", &priors).ok());
  EXPECT_EQ(priors.default_fusion_distance_m, 0.3);
  EXPECT_TRUE(priors.all().empty());
  EXPECT_EQ(priors.fusionDistance("chair"), 0.3);

  ASSERT_TRUE(ClassPriors::parseYaml("default_fusion_distance_m: 0.4\nclasses:\n", &priors).ok());
  EXPECT_TRUE(priors.all().empty());
}

struct BadYaml {
  const char* what;
  const char* yaml;
  std::vector<std::string> message_has;
};

TEST(ClassPriorsTest, EachErrorNamesTheEntryAndLeavesThePriorsUnchanged) {
  const std::vector<BadYaml> cases = {
      {"syntax", "classes: {chair: [0.5, 0.5", {"syntax"}},
      {"empty document", "", {"empty"}},
      {"top level not a map", "- chair\n- cup\n", {"top level"}},
      {"unknown top-level key", "default_fusion_distance: 0.5\n", {"default_fusion_distance"}},
      {"classes a list", "classes: [chair, cup]\n", {"classes", "map"}},
      {"classes a scalar", "classes: chair\n", {"classes", "map"}},
      {"two sizes", "classes: {chair: {size_m: [0.5, 0.9]}}", {"chair", "size_m", "0.5, 0.9"}},
      {"four sizes", "classes: {chair: {size_m: [0.5, 0.5, 0.9, 1]}}", {"chair", "size_m"}},
      {"negative size", "classes: {chair: {size_m: [0.5, -0.5, 0.9]}}", {"chair", "size_m"}},
      {"zero size", "classes: {chair: {size_m: [0.5, 0, 0.9]}}", {"chair", "size_m"}},
      {"text size", "classes: {chair: {size_m: [0.5, big, 0.9]}}", {"chair", "big"}},
      {"nan size", "classes: {chair: {size_m: [0.5, .nan, 0.9]}}", {"chair", "size_m"}},
      {"infinite size", "classes: {chair: {size_m: [0.5, .inf, 0.9]}}", {"chair", "size_m"}},
      {"size a scalar", "classes: {chair: {size_m: 0.5}}", {"chair", "size_m"}},
      {"negative distance",
       "classes: {cup: {fusion_distance_m: -0.1}}",
       {"cup", "fusion_distance_m", "-0.1"}},
      {"nan distance", "classes: {cup: {fusion_distance_m: .nan}}", {"cup", "fusion_distance_m"}},
      {"distance a list", "classes: {cup: {fusion_distance_m: [1]}}", {"cup", "fusion_distance_m"}},
      {"negative default", "default_fusion_distance_m: -1\n", {"default_fusion_distance_m"}},
      {"infinite default", "default_fusion_distance_m: .inf\n", {"default_fusion_distance_m"}},
      {"entry not a map", "classes: {chair: [0.5, 0.5, 0.9]}", {"chair", "map"}},
      {"unknown entry key", "classes: {chair: {size: [0.5, 0.5, 0.9]}}", {"chair", "'size'"}},
      {"on_floor not a bool", "classes: {chair: {on_floor: maybe}}", {"chair.on_floor", "maybe"}},
      {"flat_top a list", "classes: {chair: {flat_top: [true]}}", {"chair.flat_top"}},
      {"on_wall not a bool", "classes: {tv: {on_wall: often}}", {"tv.on_wall", "often"}},
      {"negative amodal depth",
       "classes: {chair: {amodal_depth_m: -0.5}}",
       {"chair.amodal_depth_m", "-0.5"}},
      {"amodal depth a word", "classes: {chair: {amodal_depth_m: deep}}", {"chair.amodal_depth_m"}},
      {"not COCO", "classes: {table: {size_m: [1, 1, 1]}}", {"'table'", "not a COCO class"}},
      {"listed twice",
       "classes: {sofa: {fusion_distance_m: 1}, couch: {fusion_distance_m: 1}}",
       {"couch", "twice"}},
  };
  for (const BadYaml& c : cases) {
    ClassPriors priors = sentinel();
    const Status status = ClassPriors::parseYaml(c.yaml, &priors);
    EXPECT_FALSE(status.ok()) << c.what;
    for (const std::string& part : c.message_has) {
      EXPECT_NE(status.message().find(part), std::string::npos)
          << c.what << ": '" << part << "' not in: " << status.message();
    }
    expectSentinel(priors);
  }
}

TEST(ClassPriorsTest, NonCocoNameSuggestsOneNameAndListsNothingHuge) {
  ClassPriors priors;
  const Status status =
      ClassPriors::parseYaml("classes: {chiar: {size_m: [0.5, 0.5, 0.9]}}", &priors);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("'chiar' is not a COCO class"), std::string::npos)
      << status.message();
  EXPECT_NE(status.message().find("did you mean 'chair'"), std::string::npos) << status.message();
  EXPECT_LT(status.message().size(), 250u) << status.message();
  EXPECT_EQ(status.message().find("toothbrush"), std::string::npos) << status.message();
  const Status table = ClassPriors::parseYaml("classes: {table: {size_m: [1, 1, 1]}}", &priors);
  EXPECT_NE(table.message().find("did you mean 'dining table'"), std::string::npos)
      << table.message();
  const Status nonsense = ClassPriors::parseYaml("classes: {xyzzy: {size_m: [1, 1, 1]}}", &priors);
  EXPECT_EQ(nonsense.message().find("did you mean"), std::string::npos) << nonsense.message();
  EXPECT_LT(nonsense.message().size(), 250u) << nonsense.message();
}

class ClassPriorsFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mvod_class_priors_test_" + std::to_string(static_cast<long>(::getpid())));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code error;
    fs::remove_all(dir_, error);
  }
  std::string write(const std::string& name, const std::string& text) {
    const fs::path path = dir_ / name;
    std::ofstream(path) << text;
    return path.string();
  }
  fs::path dir_;
};

TEST_F(ClassPriorsFileTest, LoadsAFile) {
  const std::string path = write(
      "good.yaml", "default_fusion_distance_m: 0.6\nclasses:\n  cup: {size_m: [0.1, 0.1, 0.1]}\n");
  ClassPriors priors = sentinel();
  const Status status = ClassPriors::loadYaml(path, &priors);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(priors.default_fusion_distance_m, 0.6);
  ASSERT_NE(priors.find("cup"), nullptr);
  EXPECT_EQ(priors.find("cup")->fusion_distance_m, 0.6);
}

TEST_F(ClassPriorsFileTest, ErrorsNameTheFile) {
  const std::vector<std::string> paths = {
      (dir_ / "missing.yaml").string(),
      dir_.string(),  // a directory
      write("syntax.yaml", "classes: {chair: [\n"),
      write("bad_size.yaml", "classes:\n  chair: {size_m: [1, 2]}\n"),
  };
  for (const std::string& path : paths) {
    ClassPriors priors = sentinel();
    const Status status = ClassPriors::loadYaml(path, &priors);
    EXPECT_FALSE(status.ok()) << path;
    EXPECT_NE(status.message().find(path), std::string::npos) << status.message();
    expectSentinel(priors);
  }
  ClassPriors priors;
  const Status status = ClassPriors::loadYaml(paths[3], &priors);
  EXPECT_NE(status.message().find("chair"), std::string::npos) << status.message();
}

TEST(ClassPriorsConfigFileTest, PackageConfigHasEveryRequiredClass) {
  ClassPriors priors;
  const Status status = ClassPriors::loadYaml(configPath(), &priors);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_GT(priors.default_fusion_distance_m, 0.0);
  for (const std::string& name : kRequiredClasses) {
    const ClassPrior* prior = priors.find(name);
    ASSERT_NE(prior, nullptr) << name;
    EXPECT_TRUE(prior->has_size) << name;
  }
  for (const auto& entry : priors.all()) {
    const ClassPrior& prior = entry.second;
    EXPECT_GE(cocoClassId(prior.class_name), 0) << prior.class_name;
    if (prior.has_size) {
      EXPECT_GT(prior.size_m.minCoeff(), 0.0) << prior.class_name;
      EXPECT_LT(prior.size_m.maxCoeff(), 3.0) << prior.class_name << ": an indoor object";
      // Roughly half the largest extent, at least 0.1 m.
      EXPECT_GE(prior.fusion_distance_m, 0.1) << prior.class_name;
      EXPECT_LE(prior.fusion_distance_m, std::max(0.12, 0.7 * prior.size_m.maxCoeff()))
          << prior.class_name;
    }
  }
  // Sizes a table and a chair can have.
  EXPECT_GT(priors.find("dining table")->size_m.prod(), priors.find("chair")->size_m.prod());
  EXPECT_GT(priors.find("chair")->size_m.prod(), priors.find("cup")->size_m.prod());
}

TEST(ClassPriorsTest, ParsesHowAClassStands) {
  ClassPriors priors;
  ASSERT_TRUE(ClassPriors::parseYaml("classes:\n"
                                     "  dining table: {on_floor: true, flat_top: true}\n"
                                     "  chair: {size_m: [0.55, 0.55, 0.9], on_floor: true, "
                                     "amodal_depth_m: 0.5}\n"
                                     "  cup: {fusion_distance_m: 0.1, on_floor: false}\n"
                                     "  clock: {on_wall: true}\n"
                                     "  tv:\n",
                                     &priors)
                  .ok());
  EXPECT_TRUE(priors.find("dining table")->on_floor);
  EXPECT_TRUE(priors.find("dining table")->flat_top);
  EXPECT_TRUE(priors.find("chair")->on_floor);
  EXPECT_FALSE(priors.find("chair")->flat_top);
  EXPECT_FALSE(priors.find("cup")->on_floor);
  EXPECT_FALSE(priors.find("tv")->on_floor);  // not given: false
  EXPECT_FALSE(priors.find("tv")->flat_top);
  EXPECT_TRUE(priors.find("clock")->on_wall);
  EXPECT_FALSE(priors.find("tv")->on_wall);  // not given: false
  EXPECT_DOUBLE_EQ(priors.find("chair")->amodal_depth_m, 0.5);
  EXPECT_EQ(priors.find("dining table")->amodal_depth_m, 0.0);  // not given: never completed
}

// The package's file: furniture stands on the floor, the dining table has a flat top, and small
// things that stand on tables do neither.
TEST(ClassPriorsConfigFileTest, PackageConfigSaysHowFurnitureStands) {
  ClassPriors priors;
  ASSERT_TRUE(ClassPriors::loadYaml(configPath(), &priors).ok());
  for (const char* name : {"chair", "couch", "bed", "dining table", "refrigerator"}) {
    ASSERT_NE(priors.find(name), nullptr) << name;
    EXPECT_TRUE(priors.find(name)->on_floor) << name;
  }
  EXPECT_TRUE(priors.find("dining table")->flat_top);
  // Chairs are completed (a chair's depth, seat to backrest); tables are grounded instead.
  EXPECT_GT(priors.find("chair")->amodal_depth_m, 0.4);
  EXPECT_LT(priors.find("chair")->amodal_depth_m, 0.7);
  EXPECT_EQ(priors.find("dining table")->amodal_depth_m, 0.0);
  for (const char* name : {"cup", "book", "tv", "laptop", "bottle"}) {
    ASSERT_NE(priors.find(name), nullptr) << name;
    EXPECT_FALSE(priors.find(name)->on_floor) << name;
    EXPECT_FALSE(priors.find(name)->flat_top) << name;
  }
  // Wall monitors and clocks hang on walls; what stands on tables and floors does not.
  EXPECT_TRUE(priors.find("tv")->on_wall);
  EXPECT_TRUE(priors.find("clock")->on_wall);
  for (const char* name : {"cup", "book", "laptop", "chair", "dining table"}) {
    EXPECT_FALSE(priors.find(name)->on_wall) << name;
  }
}

// The objects of the synthetic scene and 7-Scenes' table pass Eq. 9 with the default thresholds,
// and the paper's atypical chair does not.
TEST(ClassPriorsConfigFileTest, PackageConfigKeepsRealisticObjects) {
  ClassPriors priors;
  ASSERT_TRUE(ClassPriors::loadYaml(configPath(), &priors).ok());
  const PriorSizeFilter filter;
  auto typical = [&](const std::string& class_name, const Eigen::Vector3d& size_m) {
    MapObject object;
    object.class_name = class_name;
    object.box.size_m = size_m;
    return filter.isTypical(object, priors);
  };
  EXPECT_TRUE(typical("dining table", Eigen::Vector3d(1.6, 0.9, 0.75)));
  EXPECT_TRUE(typical("dining table", Eigen::Vector3d(1.2, 0.8, 0.73)));  // 7-Scenes redkitchen
  EXPECT_TRUE(typical("chair", Eigen::Vector3d(0.5, 0.5, 0.9)));
  EXPECT_TRUE(typical("couch", Eigen::Vector3d(2.0, 0.9, 0.85)));
  EXPECT_TRUE(typical("tv", Eigen::Vector3d(1.0, 0.08, 0.6)));
  EXPECT_TRUE(typical("tv", Eigen::Vector3d(0.6, 0.05, 0.35)));
  EXPECT_TRUE(typical("cup", Eigen::Vector3d(0.08, 0.08, 0.1)));
  EXPECT_TRUE(typical("book", Eigen::Vector3d(0.2, 0.15, 0.04)));
  EXPECT_TRUE(typical("person", Eigen::Vector3d(0.6, 0.6, 1.3)));  // sitting
  EXPECT_FALSE(typical("chair", Eigen::Vector3d(0.10, 0.15, 0.05)));
  EXPECT_FALSE(typical("cup", Eigen::Vector3d(0.9, 0.5, 0.9)));
  EXPECT_FALSE(typical("dining table", Eigen::Vector3d(1.6, 0.9, 0.02)));  // the top alone
}

}  // namespace
}  // namespace mvod
