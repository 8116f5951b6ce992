// Writes the seed corpora of the fuzz harnesses (test/fuzz/<harness>_corpus/): small files in the
// real formats, made here rather than copied from data. Run once when a format changes:
//   clang++ -std=c++17 -Iinclude -I/usr/include/eigen3 $(pkg-config --cflags opencv4) \
//     test/fuzz/make_seed_corpus.cpp src/io/json_io.cpp src/io/object_json.cpp \
//     src/io/history_json.cpp src/io/image_io.cpp src/pipeline/types/common.cpp \
//     -lopencv_imgcodecs -lopencv_imgproc -lopencv_core \
//     -o /tmp/make_seed_corpus && /tmp/make_seed_corpus test/fuzz
#include <cstdint>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace fs = std::filesystem;

namespace {

void writeBytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

std::string encode(const std::string& extension, const cv::Mat& image,
                   const std::vector<int>& params = {}) {
  std::vector<uint8_t> buffer;
  cv::imencode(extension, image, buffer, params);
  return std::string(buffer.begin(), buffer.end());
}

// A PNG whose IHDR claims width x height with a tiny IDAT: what a 20000x20000 bomb's header says.
std::string pngHeaderClaiming(uint32_t width, uint32_t height) {
  std::string png = encode(".png", cv::Mat::zeros(2, 2, CV_16UC1));
  for (int i = 0; i < 4; ++i) {
    png[16 + i] = static_cast<char>((width >> (24 - 8 * i)) & 0xFF);
    png[20 + i] = static_cast<char>((height >> (24 - 8 * i)) & 0xFF);
  }
  return png;  // the IHDR CRC is now wrong, which a decoder must also survive
}

void mapCorpus(const fs::path& dir) {
  mvod::MapSummary summary;
  summary.frames = 120;
  summary.keyframes = 12;
  summary.gravity_down_W = Eigen::Vector3d(0, 0, -1);
  summary.counts.detections = 30;
  summary.counts.inserted = 2;
  writeBytes(dir / "empty.json", mvod::objectsToJson({}, summary, false));

  mvod::MapObject chair;
  chair.id = 3;
  chair.class_id = 56;
  chair.class_name = "chair";
  chair.probability = 0.8125;
  chair.observations = 4;
  chair.box.center_m = Eigen::Vector3d(1.25, -0.5, 0.45);
  chair.box.size_m = Eigen::Vector3d(0.5, 0.55, 0.9);
  chair.box.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  chair.yaw_rad = 0.3;
  chair.first_keyframe = 2;
  chair.last_keyframe = 9;
  chair.first_seen_s = 0.5;
  chair.last_seen_s = 3.25;
  chair.class_scores = {{"chair", 2.5}, {"couch", 0.75}};
  writeBytes(dir / "one_object.json", mvod::objectsToJson({chair}, summary, false));

  for (int i = 0; i < 6; ++i) {
    chair.points_W.emplace_back(1.0f + 0.01f * i, -0.5f, 0.1f * i);
    chair.segment_W.emplace_back(1.0f + 0.01f * i, -0.5f, 0.1f * i);
  }
  chair.evidence_voxel_size_m = 0.02;
  chair.evidence[mvod::packVoxel(Eigen::Vector3i(50, -25, 3))] = mvod::VoxelEvidence{3, 1};
  chair.evidence[mvod::packVoxel(Eigen::Vector3i(-1, 0, 7))] = mvod::VoxelEvidence{1, 0};
  // A voxel with the views' summed normals (an 8-element voxel in the file).
  chair.evidence[mvod::packVoxel(Eigen::Vector3i(2, 2, 2))] =
      mvod::VoxelEvidence{2, 0, Eigen::Vector3f(0.25f, -1.5f, 0.125f)};
  // ... and with the views' summed signed distances (a 10-element voxel).
  chair.evidence[mvod::packVoxel(Eigen::Vector3i(2, 2, 3))] =
      mvod::VoxelEvidence{2, 1, Eigen::Vector3f(0.5f, 0.f, 0.f), 3, -0.03125f};
  mvod::MapObject table = chair;
  table.id = 7;
  table.class_id = 60;
  table.class_name = "dining table";
  table.class_scores.clear();
  table.evidence.clear();
  table.evidence_voxel_size_m = 0.0;
  const std::string with_clouds = mvod::objectsToJson({chair, table}, summary, true);
  writeBytes(dir / "with_clouds.json", with_clouds);
  // The fuzzer's first find: an evidence grid without voxels did not round-trip.
  std::string empty_evidence = with_clouds;
  const size_t at = empty_evidence.rfind("\"points\":");
  empty_evidence.insert(at, "\"evidence\":{\"voxel_size_m\":0.02,\"voxels\":[]},");
  writeBytes(dir / "regression_empty_evidence.json", empty_evidence);

  // A map with its keyframe history (a 16-bit depth image, one view).
  mvod::KeyframeRecord record;
  record.keyframe = 4;
  record.stamp_s = 12.5;
  record.name = "frame-000040";
  record.T_W_D_recorded.translation() = Eigen::Vector3d(0.5, 0.25, 1.0);
  record.T_W_D = record.T_W_D_recorded;
  record.K_depth = mvod::CameraIntrinsics{525.0, 525.0, 3.5, 2.5, 8, 6};
  record.depth = cv::Mat(6, 8, CV_16UC1, cv::Scalar(1500));
  record.has_floor = true;
  record.floor_point_D = Eigen::Vector3d(0.0, 1.2, 0.5);
  mvod::RecordedView view;
  view.class_id = 56;
  view.class_name = "chair";
  view.probability = 0.75;
  view.box = chair.box;
  view.yaw_rad = chair.yaw_rad;
  view.object_id = chair.id;
  auto cut = std::make_shared<mvod::RecordedCut>();
  cut->cut_W = {Eigen::Vector3f(1.25f, -0.5f, 0.5f), Eigen::Vector3f(1.3f, -0.45f, 0.6f)};
  cut->normals_W = {Eigen::Vector3f(0.f, 0.f, 1.f), Eigen::Vector3f(1.f, 0.f, 0.f)};
  cut->outside_keys = {mvod::packVoxel(Eigen::Vector3i(125, -50, 40))};
  cut->voxel_size_m = 0.01;
  view.cut = cut;
  record.views.push_back(view);
  const std::deque<mvod::KeyframeRecord> history = {record};
  writeBytes(dir / "with_history.json", mvod::objectsToJson({chair}, summary, true, &history));
}

void detectionCorpus(const fs::path& dir) {
  writeBytes(dir / "empty.json", "[]\n");
  writeBytes(dir / "boxes.json",
             "[{\"class_name\": \"chair\", \"score\": 0.9, \"box\": [1, 2, 10, 12]},\n"
             " {\"class_id\": 62, \"score\": 0.6, \"box\": [2.5, 2, 6, 6.5]},\n"
             " {\"class_name\": \"sofa\", \"score\": 0.4, \"box\": [-5, -3, 40, 30]}]\n");
  writeBytes(dir / "masks.json",
             "[{\"class_name\": \"tv\", \"score\": 0.7, \"mask\": \"m.png\"},\n"
             " {\"class_name\": \"cup\", \"score\": 0.75, \"box\": [0, 0, 4, 4], \"mask\": "
             "\"small.png\"},\n"
             " {\"class_name\": \"cup\", \"score\": 0.5, \"box\": [0, 0, 4, 4], \"mask\": "
             "\"missing.png\"}]\n");
  writeBytes(dir / "bad_entries.json",
             "[{\"class_name\": \"unicorn\", \"score\": 0.9, \"box\": [1, 1, 5, 5]},\n"
             " {\"class_name\": \"cup\", \"score\": 87.5, \"box\": [0, 0, 4, 4]},\n"
             " {\"class_name\": \"cup\", \"score\": 1e30, \"box\": [0, 0, 4, 4]},\n"
             " {\"class_name\": \"cup\", \"score\": 0.5, \"box\": [5, 5, 2, 8]},\n"
             " \"not an object\", null, {\"class_name\": 3}]\n");
  std::string many = "[";
  for (int i = 0; i < 12; ++i) {
    many += std::string(i ? ",\n" : "") + "{\"class_name\": \"bottle\", \"score\": 0." +
            std::to_string(10 + 7 * i) + ", \"box\": [" + std::to_string(i) + ", 1, " +
            std::to_string(i + 3) + ", 9]}";
  }
  writeBytes(dir / "many.json", many + "]\n");
}

void imageCorpus(const fs::path& dir) {
  // First byte: bit 0 = colour, bit 1 = expected size 32x24 (see fuzz_image_decode.cpp).
  cv::Mat depth(24, 32, CV_16UC1);
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) depth.at<uint16_t>(v, u) = 800 + 13 * u + 7 * v;
  }
  cv::Mat mask = cv::Mat::zeros(24, 32, CV_8UC1);
  mask(cv::Rect(4, 5, 10, 8)).setTo(255);
  cv::Mat colour(24, 32, CV_8UC3);
  cv::randu(colour, cv::Scalar::all(0), cv::Scalar::all(255));
  writeBytes(dir / "depth16.png", std::string("\x02") + encode(".png", depth));
  writeBytes(dir / "mask8.png", std::string("\x02") + encode(".png", mask));
  writeBytes(dir / "colour.png", std::string("\x03") + encode(".png", colour));
  writeBytes(dir / "colour.jpg",
             std::string("\x01") + encode(".jpg", colour, {cv::IMWRITE_JPEG_QUALITY, 50}));
  writeBytes(dir / "colour_progressive.jpg",
             std::string("\x03") + encode(".jpg", colour, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  writeBytes(dir / "bomb_header.png", std::string("\x00", 1) + pngHeaderClaiming(20000, 20000));
  writeBytes(dir / "wrong_size.png",
             std::string("\x02") + encode(".png", mask(cv::Rect(0, 0, 8, 6))));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_seed_corpus TEST_FUZZ_DIR\n");
    return 2;
  }
  const fs::path root(argv[1]);
  const std::pair<const char*, void (*)(const fs::path&)> corpora[] = {
      {"map_json_corpus", mapCorpus},
      {"detection_json_corpus", detectionCorpus},
      {"image_decode_corpus", imageCorpus}};
  for (const auto& corpus : corpora) {
    const fs::path dir = root / corpus.first;
    fs::remove_all(dir);
    fs::create_directories(dir);
    corpus.second(dir);
  }
  return 0;
}
