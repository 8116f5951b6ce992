// rostest (node_changing_room.test): the map follows the room through the node. Two laps of the
// synthetic scene, changed between them as people change a home: a chair moved 1.6 m, the couch
// taken away. After the second lap ~get_objects holds the chair once, at its new place, and no
// couch; the removed objects were announced on ~removed_objects, their markers deleted and counted
// on /diagnostics. A map saved then and loaded into a second node keeps every object's existence.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "multiview_object_detection/GetObjects.h"
#include "multiview_object_detection/MapFile.h"
#include "std_srvs/Trigger.h"
#include "test_node_common.h"

namespace mvod_test {
namespace {

using multiview_object_detection::GetObjects;
using multiview_object_detection::MapFile;
using multiview_object_detection::Object;
using multiview_object_detection::ObjectArray;

constexpr char kNode[] = "/object_detection";
constexpr char kSecondNode[] = "/object_detection_2";
constexpr int kFramesPerLap = 12;
constexpr int kChair = 1;  // objects() of the default room: 0 table, 1-4 chairs, 5 couch, 6 tv
constexpr int kCouch = 5;

std::string describe(const ObjectArray& objects) {
  std::string text;
  char line[200];
  for (const Object& object : objects.objects) {
    std::snprintf(line, sizeof(line),
                  "  #%d %s centre (%.2f %.2f %.2f) existence %.2f (%u detected, %u missed, %u "
                  "seen through)\n",
                  object.id, object.class_name.c_str(), object.pose.position.x,
                  object.pose.position.y, object.pose.position.z, object.existence,
                  object.views_detected, object.views_missed, object.views_seen_through);
    text += line;
  }
  return text;
}

// The objects of `class_name` within `radius_m` (horizontally) of `centre`.
int near(const ObjectArray& map, const std::string& class_name, const Eigen::Vector3d& centre,
         double radius_m) {
  int count = 0;
  for (const Object& object : map.objects) {
    if (object.class_name == class_name &&
        (centerOf(object) - centre).head<2>().norm() < radius_m) {
      ++count;
    }
  }
  return count;
}

class NodeChangingRoomTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    SyntheticStream::Options options;
    options.num_frames = kFramesPerLap;
    before_ = new SyntheticStream(options);
    options.moved[kChair] = Eigen::Vector3d(1.6, 0.0, 0.0);
    options.removed.insert(kCouch);
    after_ = new SyntheticStream(options);
    inputs_ = new InputPublisher(*nh_);
    outputs_ = new NodeOutputs(*nh_, kNode);
    second_outputs_ = new NodeOutputs(*nh_, kSecondNode);
    removed_sub_ = nh_->subscribe<ObjectArray>(
        std::string(kNode) + "/removed_objects", 100,
        boost::function<void(const ObjectArray::ConstPtr&)>([](const ObjectArray::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          for (const Object& object : msg->objects) removed_.objects.push_back(object);
        }));
    diagnostics_sub_ = nh_->subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 10,
        boost::function<void(const diagnostic_msgs::DiagnosticArray::ConstPtr&)>(
            [](const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
              for (const diagnostic_msgs::DiagnosticStatus& status : msg->status) {
                if (status.name.rfind(std::string(kNode + 1) + ":", 0) != 0) {  // "<node>: <task>"
                  continue;
                }
                std::lock_guard<std::mutex> lock(mutex_);
                for (const diagnostic_msgs::KeyValue& kv : status.values) {
                  diagnostics_[kv.key] = kv.value;
                }
              }
            }));
    connected_ = outputs_->waitFor(
        [] {
          return inputs_->connected() && outputs_->connected() && second_outputs_->connected() &&
                 removed_sub_.getNumPublishers() > 0;
        },
        30.0);
    if (!connected_) return;
    ros::WallDuration(0.5).sleep();
    const ros::Time start = ros::Time::now();
    for (int i = 0; i < 2 * kFramesPerLap; ++i) {
      const ros::Time stamp = start + ros::Duration(0.5 * i);
      const SyntheticStream& stream = i < kFramesPerLap ? *before_ : *after_;
      inputs_->publish(stream.make(i % kFramesPerLap, stamp));
      all_processed_ = outputs_->waitForObjectsAt(stamp, 20.0) && all_processed_;
      if (i == kFramesPerLap - 1) first_lap_ = getObjects(kNode);
    }
    // As the offline runner does at the end: the refinement merges what two views split.
    std_srvs::Trigger refine;
    ros::service::call(std::string(kNode) + "/refine", refine);
    final_ = getObjects(kNode);
  }

  static void TearDownTestSuite() {
    removed_sub_.shutdown();
    diagnostics_sub_.shutdown();
    delete second_outputs_;
    delete outputs_;
    delete inputs_;
    delete after_;
    delete before_;
    delete nh_;
  }

  void SetUp() override { ASSERT_TRUE(connected_) << "the nodes' topics did not connect"; }

  static ObjectArray removed() {
    std::lock_guard<std::mutex> lock(mutex_);
    return removed_;
  }
  static int diagnostic(const std::string& key) {
    std::lock_guard<std::mutex> lock(mutex_);
    return diagnostics_.count(key) ? std::stoi(diagnostics_[key]) : -1;
  }

  static ros::NodeHandle* nh_;
  static SyntheticStream* before_;
  static SyntheticStream* after_;
  static InputPublisher* inputs_;
  static NodeOutputs* outputs_;
  static NodeOutputs* second_outputs_;
  static ros::Subscriber removed_sub_, diagnostics_sub_;
  static std::mutex mutex_;
  static ObjectArray removed_;
  static std::map<std::string, std::string> diagnostics_;
  static bool connected_;
  static bool all_processed_;
  static ObjectArray first_lap_, final_;
};

ros::NodeHandle* NodeChangingRoomTest::nh_ = nullptr;
SyntheticStream* NodeChangingRoomTest::before_ = nullptr;
SyntheticStream* NodeChangingRoomTest::after_ = nullptr;
InputPublisher* NodeChangingRoomTest::inputs_ = nullptr;
NodeOutputs* NodeChangingRoomTest::outputs_ = nullptr;
NodeOutputs* NodeChangingRoomTest::second_outputs_ = nullptr;
ros::Subscriber NodeChangingRoomTest::removed_sub_;
ros::Subscriber NodeChangingRoomTest::diagnostics_sub_;
std::mutex NodeChangingRoomTest::mutex_;
ObjectArray NodeChangingRoomTest::removed_;
std::map<std::string, std::string> NodeChangingRoomTest::diagnostics_;
bool NodeChangingRoomTest::connected_ = false;
bool NodeChangingRoomTest::all_processed_ = true;
ObjectArray NodeChangingRoomTest::first_lap_;
ObjectArray NodeChangingRoomTest::final_;

TEST_F(NodeChangingRoomTest, TheMovedChairIsMappedOnceAndTheCouchIsGone) {
  ASSERT_TRUE(all_processed_) << "not every keyframe was processed";
  const Eigen::Vector3d old_place = before_->scene().objects()[kChair].box.center_m;
  const Eigen::Vector3d new_place = after_->scene().objects()[kChair].box.center_m;
  const Eigen::Vector3d couch = before_->scene().objects()[kCouch].box.center_m;
  // The first lap mapped the chair and the couch where they stood.
  ASSERT_EQ(near(first_lap_, "chair", old_place, 0.3), 1) << describe(first_lap_);
  ASSERT_EQ(near(first_lap_, "couch", couch, 0.5), 1) << describe(first_lap_);

  EXPECT_EQ(near(final_, "chair", old_place, 0.3), 0) << "the chair's old place:\n"
                                                      << describe(final_);
  EXPECT_EQ(near(final_, "chair", new_place, 0.3), 1) << "the chair's new place:\n"
                                                      << describe(final_);
  EXPECT_EQ(near(final_, "couch", couch, 1.0), 0) << describe(final_);
  // Nothing else went: the table and the other three chairs are still there.
  EXPECT_EQ(near(final_, "dining table", before_->scene().objects()[0].box.center_m, 0.3), 1)
      << describe(final_);
  for (int chair = 2; chair <= 4; ++chair) {
    EXPECT_EQ(near(final_, "chair", before_->scene().objects()[chair].box.center_m, 0.3), 1)
        << "chair " << chair << ":\n"
        << describe(final_);
  }
}

TEST_F(NodeChangingRoomTest, RemovedObjectsAreAnnouncedDeletedFromRvizAndCounted) {
  const Eigen::Vector3d old_place = before_->scene().objects()[kChair].box.center_m;
  const Eigen::Vector3d couch = before_->scene().objects()[kCouch].box.center_m;
  ASSERT_TRUE(outputs_->waitFor([] { return removed().objects.size() >= 2; }, 5.0))
      << "~removed_objects announced " << removed().objects.size() << " objects";
  const ObjectArray gone = removed();
  EXPECT_EQ(near(gone, "chair", old_place, 0.3), 1) << describe(gone);
  EXPECT_EQ(near(gone, "couch", couch, 0.5), 1) << describe(gone);
  std::set<int> final_ids;
  for (const Object& object : final_.objects) final_ids.insert(object.id);
  int gone_by_existence = 0;
  for (const Object& object : gone.objects) {
    EXPECT_EQ(final_ids.count(object.id), 0u) << "#" << object.id << " announced gone but mapped";
    EXPECT_FALSE(object.removed_reason.empty()) << "#" << object.id;
    // The final ~refine's removals are announced too (a partial view inside the object it belongs
    // to); the rules below are the existence evidence's.
    if (object.removed_reason.rfind("refinement: ", 0) == 0) continue;
    ++gone_by_existence;
    // The other removal rule: a detection that did not repeat (one view, then missed by the
    // keyframes that show its place). Since a keyframe's detections are associated at once and
    // Γ_C no longer joins what the view saw apart, this room has one such chair (the log: "chair
    // #12 gone: a detection that did not repeat: detected in 1 of the 8 keyframes").
    if (object.observations == 1) continue;
    EXPECT_LT(object.existence, 0.5) << "#" << object.id;
    EXPECT_GT(object.views_seen_through, 0u) << "#" << object.id;
  }
  // rviz shows the map and nothing else: the removed objects' boxes were deleted.
  EXPECT_TRUE(outputs_->waitFor([&] { return outputs_->shownIds("boxes") == final_ids; }, 5.0))
      << "the markers do not show the map";
  EXPECT_TRUE(
      outputs_->waitFor([&] { return diagnostic("removed gone") >= gone_by_existence; }, 10.0))
      << "/diagnostics 'removed gone' is " << diagnostic("removed gone");
}

TEST_F(NodeChangingRoomTest, ASavedMapKeepsItsExistenceInASecondNode) {
  const ObjectArray first = getObjects(kNode);
  ASSERT_FALSE(first.objects.empty());
  ASSERT_EQ(copyMap(kNode, kSecondNode), "");
  const ObjectArray loaded = getObjects(kSecondNode);
  ASSERT_EQ(loaded.objects.size(), first.objects.size());
  int with_evidence = 0;
  for (const Object& object : first.objects) {
    const auto same = std::find_if(loaded.objects.begin(), loaded.objects.end(),
                                   [&](const Object& o) { return o.id == object.id; });
    ASSERT_NE(same, loaded.objects.end()) << "#" << object.id << " not loaded";
    EXPECT_NEAR(same->existence, object.existence, 1e-5) << "#" << object.id;
    EXPECT_EQ(same->views_detected, object.views_detected) << "#" << object.id;
    EXPECT_EQ(same->views_missed, object.views_missed) << "#" << object.id;
    EXPECT_EQ(same->views_seen_through, object.views_seen_through) << "#" << object.id;
    if (object.views_detected > 1) ++with_evidence;
  }
  EXPECT_GT(with_evidence, 0) << "no object gathered evidence:\n" << describe(first);
}

// Three keyframes of depth 9.9 m everywhere (a valid value) at the map's own poses: a sensor
// fault, not an empty room. No object goes, the keyframes are counted on /diagnostics.
TEST_F(NodeChangingRoomTest, ThreeKeyframesOfFarDepthRemoveNothing) {
  const ObjectArray before = getObjects(kNode);
  ASSERT_FALSE(before.objects.empty());
  const size_t announced = removed().objects.size();
  const ros::Time start = ros::Time::now() + ros::Duration(1.0);
  for (int i = 0; i < 3; ++i) {
    const ros::Time stamp = start + ros::Duration(0.5 * i);
    FrameMsgs msgs = after_->make(i, stamp);
    ASSERT_EQ(msgs.depth.encoding, "16UC1");
    for (size_t k = 0; k + 1 < msgs.depth.data.size(); k += 2) {
      const std::uint16_t far_mm = 9900;
      std::memcpy(&msgs.depth.data[k], &far_mm, sizeof(far_mm));
    }
    inputs_->publish(msgs);
    ASSERT_TRUE(outputs_->waitForObjectsAt(stamp, 20.0)) << "keyframe " << i << " not processed";
  }
  const ObjectArray after = getObjects(kNode);
  for (const Object& object : before.objects) {
    const auto same = std::find_if(after.objects.begin(), after.objects.end(),
                                   [&](const Object& o) { return o.id == object.id; });
    EXPECT_NE(same, after.objects.end())
        << "#" << object.id << " " << object.class_name << " removed:\n"
        << describe(after);
  }
  EXPECT_EQ(after.objects.size(), before.objects.size()) << describe(after);
  EXPECT_EQ(removed().objects.size(), announced);
  EXPECT_TRUE(outputs_->waitFor([] { return diagnostic("keyframes taken for faults") >= 3; }, 10.0))
      << "/diagnostics 'keyframes taken for faults' is "
      << diagnostic("keyframes taken for faults");
}

}  // namespace
}  // namespace mvod_test

int main(int argc, char** argv) {
  return mvod_test::runRosTests(argc, argv, "test_node_changing_room");
}
