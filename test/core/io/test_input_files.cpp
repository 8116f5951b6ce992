// Hostile offline input files (issue 12): image bombs refused from their header before any
// decoding, a missing depth image warned about, an out-of-range gravity file refused, a folder as
// <frame>.json an error (not an exception), too many detections capped with a warning, scores
// that are not probabilities dropped with a warning naming the file and the value.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/datasets/dataset.h"
#include "multiview_object_detection/datasets/dataset_source.h"
#include "multiview_object_detection/datasets/scenenn_dataset.h"
#include "multiview_object_detection/detectors/file_instance_segmenter.h"
#include "multiview_object_detection/io/image_io.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

// ---- A genuine PNG bomb, made without zlib: a 1-bit greyscale image whose raw rows are all
// zero bytes compress (deflate, fixed Huffman codes: one literal 0, then back-references of 258
// bytes at distance 1) to about 13 bits per 258 bytes. 20000x20000 is ~300 KB on disk and
// 400 MB once OpenCV has decoded it (one byte per pixel).

class BitWriter {
 public:
  // Deflate packs bits from the least significant end.
  void bits(uint32_t value, int count) {
    for (int i = 0; i < count; ++i) put((value >> i) & 1u);
  }
  // Huffman codes are sent most significant bit first.
  void code(uint32_t value, int count) {
    for (int i = count - 1; i >= 0; --i) put((value >> i) & 1u);
  }
  std::string finish() {
    if (used_ > 0) bytes_.push_back(static_cast<char>(current_));
    used_ = 0;
    current_ = 0;
    return bytes_;
  }

 private:
  void put(uint32_t bit) {
    current_ |= bit << used_;
    if (++used_ == 8) {
      bytes_.push_back(static_cast<char>(current_));
      used_ = 0;
      current_ = 0;
    }
  }
  std::string bytes_;
  uint32_t current_ = 0;
  int used_ = 0;
};

// zlib stream of `count` zero bytes.
std::string zlibZeros(uint64_t count) {
  BitWriter w;
  w.bits(1, 1);                                   // BFINAL
  w.bits(1, 2);                                   // BTYPE = fixed Huffman
  auto literal_zero = [&w] { w.code(0x30, 8); };  // literal 0..143: 0x30 + value, 8 bits
  uint64_t left = count;
  if (left > 0) {
    literal_zero();
    --left;
  }
  while (left >= 258) {
    w.code(0xC5, 8);  // length 258 = code 285: 11000101 (280..287 are 8 bits from 0xC0)
    w.code(0, 5);     // distance 1 = distance code 0
    left -= 258;
  }
  for (; left > 0; --left) literal_zero();
  w.code(0, 7);  // end of block (256): 7 zero bits
  std::string stream = "\x78\x01" + w.finish();
  const uint32_t a = 1, b = static_cast<uint32_t>(count % 65521);  // adler32 of zeros
  const uint32_t adler = (b << 16) | a;
  for (int i = 3; i >= 0; --i) stream.push_back(static_cast<char>((adler >> (8 * i)) & 0xFF));
  return stream;
}

uint32_t crc32(const std::string& bytes) {
  uint32_t crc = 0xFFFFFFFFu;
  for (const char c : bytes) {
    crc ^= static_cast<uint8_t>(c);
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xFFFFFFFFu;
}

std::string bigEndian(uint32_t value) {
  std::string out;
  for (int i = 3; i >= 0; --i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xFF));
  return out;
}

std::string pngChunk(const std::string& type, const std::string& data) {
  return bigEndian(static_cast<uint32_t>(data.size())) + type + data +
         bigEndian(crc32(type + data));
}

// A valid all-black 1-bit greyscale PNG of width x height.
std::string blackPng(uint32_t width, uint32_t height) {
  const std::string ihdr =
      bigEndian(width) + bigEndian(height) + std::string("\x01\x00\x00\x00\x00", 5);
  const uint64_t row_bytes = 1 + (width + 7) / 8;  // filter byte + packed bits
  return std::string("\x89PNG\r\n\x1A\n", 8) + pngChunk("IHDR", ihdr) +
         pngChunk("IDAT", zlibZeros(row_bytes * height)) + pngChunk("IEND", "");
}

void writeBytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

// The peak resident memory (kB) since resetPeakMemory(); -1 when the kernel does not offer it.
bool resetPeakMemory() {
  std::ofstream clear("/proc/self/clear_refs");
  clear << "5";
  clear.flush();
  return static_cast<bool>(clear);
}
long peakMemoryKb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

void expectContains(const std::string& text, const std::vector<std::string>& fragments) {
  for (const std::string& fragment : fragments) {
    EXPECT_NE(text.find(fragment), std::string::npos) << "'" << fragment << "' not in: " << text;
  }
}

TEST(ImageIoTest, TheBombGeneratorMakesRealPngs) {
  // The same generator at a small size decodes to what it claims: the bomb below is a real image.
  const std::string png = blackPng(203, 37);
  const std::vector<uint8_t> bytes(png.begin(), png.end());
  const cv::Mat decoded = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(decoded.empty());
  EXPECT_EQ(decoded.size(), cv::Size(203, 37));
  EXPECT_EQ(cv::countNonZero(decoded), 0);
  cv::Mat checked;
  ASSERT_TRUE(decodeImageChecked(bytes, "small.png", cv::IMREAD_UNCHANGED, cv::Size(203, 37),
                                 kDefaultMaxImagePixels, &checked)
                  .ok());
  EXPECT_EQ(checked.size(), cv::Size(203, 37));
}

TEST(ImageIoTest, PngBombIsRefusedFromItsHeaderWithoutDecoding) {
  const fs::path dir = test::freshTestDir("mvod_image_io");
  const fs::path bomb = dir / "frame-000000.depth.png";
  writeBytes(bomb, blackPng(20000, 20000));
  EXPECT_LT(fs::file_size(bomb), 1u << 20);  // under 1 MB on disk, 400 MB decoded

  ImageHeader header;
  ASSERT_TRUE(readImageFileHeader(bomb.string(), &header).ok());
  EXPECT_EQ(header.format, "PNG");
  EXPECT_EQ(header.size, cv::Size(20000, 20000));

  const bool can_measure = resetPeakMemory();
  const long peak_before_kb = peakMemoryKb();
  cv::Mat image;
  // Camera size unknown: the pixel limit refuses it.
  Status status = readImageChecked(bomb.string(), cv::IMREAD_UNCHANGED, cv::Size(),
                                   kDefaultMaxImagePixels, &image);
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {bomb.string(), "20000x20000", "limit", "not decoded"});
  // Camera size known: refused as the wrong size, naming both.
  status = readImageChecked(bomb.string(), cv::IMREAD_UNCHANGED, cv::Size(640, 480),
                            kDefaultMaxImagePixels, &image, "the depth camera's size");
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {bomb.string(), "20000x20000", "640x480", "not decoded"});
  EXPECT_TRUE(image.empty());
  if (can_measure && peak_before_kb > 0) {
    // Decoding would have written 400 MB of rows.
    EXPECT_LT(peakMemoryKb() - peak_before_kb, 64 * 1024) << "the bomb was decoded";
  }
  fs::remove_all(dir);
}

TEST(ImageIoTest, HeadersOfPngAndJpegAndOtherFormats) {
  cv::Mat colour(24, 32, CV_8UC3, cv::Scalar(10, 200, 30));
  std::vector<uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", colour, jpeg));
  ImageHeader header;
  ASSERT_TRUE(readImageHeader(jpeg.data(), jpeg.size(), "c.jpg", &header).ok());
  EXPECT_EQ(header.format, "JPEG");
  EXPECT_EQ(header.size, cv::Size(32, 24));
  cv::Mat decoded;
  EXPECT_TRUE(decodeImageChecked(jpeg, "c.jpg", cv::IMREAD_COLOR, cv::Size(32, 24),
                                 kDefaultMaxImagePixels, &decoded)
                  .ok());
  EXPECT_EQ(decoded.size(), cv::Size(32, 24));
  // A JPEG claiming more pixels than allowed.
  EXPECT_FALSE(
      decodeImageChecked(jpeg, "c.jpg", cv::IMREAD_COLOR, cv::Size(), 32 * 24 - 1, &decoded).ok());

  // Formats whose header is not parsed here are not decoded at all.
  std::vector<uint8_t> bmp;
  ASSERT_TRUE(cv::imencode(".bmp", colour, bmp));
  const Status status = decodeImageChecked(bmp, "c.bmp", cv::IMREAD_COLOR, cv::Size(),
                                           kDefaultMaxImagePixels, &decoded);
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {"c.bmp", "not a PNG or JPEG"});
  // Cut short.
  const std::vector<uint8_t> truncated(jpeg.begin(), jpeg.begin() + 40);
  EXPECT_FALSE(decodeImageChecked(truncated, "t.jpg", cv::IMREAD_COLOR, cv::Size(),
                                  kDefaultMaxImagePixels, &decoded)
                   .ok());
}

TEST(ImageIoTest, FoldersAreNotImages) {
  const fs::path dir = test::freshTestDir("mvod_image_io");
  cv::Mat image;
  const Status status = readImageChecked(dir.string(), cv::IMREAD_UNCHANGED, cv::Size(),
                                         kDefaultMaxImagePixels, &image);
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {dir.string(), "not a regular file"});
  fs::remove_all(dir);
}

// ---- Datasets

class InputFilesDatasetTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::freshTestDir("mvod_input_files"); }
  void TearDown() override { fs::remove_all(dir_); }

  void writeText(const std::string& file, const std::string& text) {
    std::ofstream(dir_ / file) << text;
  }

  // A registered 7-Scenes-layout folder: frames 0..2 with 8x6 depth and colour.
  void writeSevenScenes() {
    writeText("camera-intrinsics.txt", "585 0 4\n0 585 3\n0 0 1\n");
    for (int index = 0; index < 3; ++index) writeFrame(index);
  }
  void writeFrame(int index) {
    const std::string stem = SevenScenesDataset::frameName(index);
    cv::Mat depth(6, 8, CV_16UC1, cv::Scalar(1000 + index));
    cv::Mat colour(6, 8, CV_8UC3, cv::Scalar(10, 20, 30));
    ASSERT_TRUE(cv::imwrite((dir_ / (stem + ".depth.png")).string(), depth));
    ASSERT_TRUE(cv::imwrite((dir_ / (stem + ".color.png")).string(), colour));
    writeText(stem + ".pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  }

  fs::path dir_;
};

TEST_F(InputFilesDatasetTest, SevenScenesBombDepthIsRefusedNamingTheFileAndSizes) {
  writeSevenScenes();
  const fs::path bomb = dir_ / "frame-000001.depth.png";
  writeBytes(bomb, blackPng(20000, 20000));
  SevenScenesDataset dataset;
  ASSERT_TRUE(SevenScenesDataset::open(dir_.string(), &dataset).ok());
  RgbdFrame frame;
  const Status status = dataset.load(1, &frame);
  ASSERT_FALSE(status.ok());
  // The expected size is the depth camera's, learnt from frame 0's header.
  expectContains(status.message(),
                 {bomb.string(), "20000x20000", "8x6", "frame-000000.depth.png", "not decoded"});
  EXPECT_TRUE(dataset.load(0, &frame).ok());
  EXPECT_TRUE(dataset.load(2, &frame).ok());

  // A colour image of another size than the registered depth is refused before decoding too.
  writeBytes(dir_ / "frame-000002.color.png", blackPng(20000, 20000));
  const Status colour = dataset.load(2, &frame);
  ASSERT_FALSE(colour.ok());
  expectContains(colour.message(), {"frame-000002.color.png", "20000x20000", "8x6"});
}

TEST_F(InputFilesDatasetTest, SceneNNBombDepthIsRefused) {
  fs::create_directories(dir_ / "image");
  fs::create_directories(dir_ / "depth");
  std::string trajectory;
  for (int k = 1; k <= 2; ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "%05d.png", k);
    ASSERT_TRUE(cv::imwrite((dir_ / "image" / ("image" + std::string(name))).string(),
                            cv::Mat(6, 8, CV_8UC3, cv::Scalar(1, 2, 3))));
    ASSERT_TRUE(cv::imwrite((dir_ / "depth" / ("depth" + std::string(name))).string(),
                            cv::Mat(6, 8, CV_16UC1, cv::Scalar(1200))));
    trajectory += std::to_string(k - 1) + " " + std::to_string(k - 1) + " " + std::to_string(k) +
                  "\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  }
  writeText("trajectory.log", trajectory);
  const fs::path bomb = dir_ / "depth" / "depth00002.png";
  writeBytes(bomb, blackPng(20000, 20000));
  SceneNNDataset dataset;
  ASSERT_TRUE(SceneNNDataset::open(dir_.string(), &dataset).ok());
  RgbdFrame frame;
  EXPECT_TRUE(dataset.load(1, &frame).ok());
  const Status status = dataset.load(2, &frame);
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {bomb.string(), "20000x20000", "8x6", "not decoded"});
}

TEST_F(InputFilesDatasetTest, SevenScenesMissingDepthIsAWarningNamingTheFile) {
  writeSevenScenes();
  fs::remove(dir_ / "frame-000001.depth.png");
  SevenScenesDataset dataset;
  ASSERT_TRUE(SevenScenesDataset::open(dir_.string(), &dataset).ok());
  EXPECT_EQ(dataset.frameIndices(), std::vector<int>({0, 2}));
  ASSERT_EQ(dataset.warnings().size(), 1u);
  expectContains(dataset.warnings()[0], {dir_.string(), "frame-000001.depth.png", "skipped"});

  // The tools see it through the dataset source's warnings.
  DatasetSource source;
  ASSERT_TRUE(openDatasetSource(dir_.string(), "7scenes", &source).ok());
  const bool warned =
      std::any_of(source.warnings.begin(), source.warnings.end(), [](const std::string& warning) {
        return warning.find("frame-000001.depth.png") != std::string::npos;
      });
  EXPECT_TRUE(warned);

  // A complete folder has no such warning.
  writeFrame(1);
  ASSERT_TRUE(SevenScenesDataset::open(dir_.string(), &dataset).ok());
  EXPECT_TRUE(dataset.warnings().empty()) << dataset.warnings().front();
}

TEST_F(InputFilesDatasetTest, SceneNNMissingDepthIsAWarningNamingTheFile) {
  fs::create_directories(dir_ / "image");
  fs::create_directories(dir_ / "depth");
  for (int k = 1; k <= 3; ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "%05d.png", k);
    ASSERT_TRUE(cv::imwrite((dir_ / "image" / ("image" + std::string(name))).string(),
                            cv::Mat(6, 8, CV_8UC3, cv::Scalar(1, 2, 3))));
    if (k != 2) {
      ASSERT_TRUE(cv::imwrite((dir_ / "depth" / ("depth" + std::string(name))).string(),
                              cv::Mat(6, 8, CV_16UC1, cv::Scalar(1200))));
    }
  }
  writeText(
      "trajectory.log",
      "0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n2 2 3\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  SceneNNDataset dataset;
  ASSERT_TRUE(SceneNNDataset::open(dir_.string(), &dataset).ok());
  EXPECT_EQ(dataset.frameIndices(), std::vector<int>({1, 3}));
  ASSERT_EQ(dataset.warnings().size(), 1u);
  expectContains(dataset.warnings()[0], {"depth/depth00002.png", "skipped"});
  DatasetSource source;
  ASSERT_TRUE(openDatasetSource(dir_.string(), "scenenn", &source).ok());
  EXPECT_FALSE(source.warnings.empty());
}

// The tools' dataset source checks the intrinsics files against the images, as the node checks
// camera_info (checkIntrinsicsForImage): the message names the file.
TEST_F(InputFilesDatasetTest, IntrinsicsNoRgbdCameraHasAreRefusedByTheToolsSource) {
  writeSevenScenes();
  const fs::path intrinsics = dir_ / "camera-intrinsics.txt";
  auto loadStatus = [&] {
    DatasetSource source;
    const Status opened = openDatasetSource(dir_.string(), "7scenes", &source);
    EXPECT_TRUE(opened.ok()) << opened.message();
    RgbdFrame frame;
    return opened ? source.load(0, &frame) : opened;
  };
  // A 640x480 K (fx 585) on the 8x6 images: 0.8 degrees across.
  Status status = loadStatus();
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {intrinsics.string(), "field of view", "frame-000000"});
  writeText("camera-intrinsics.txt", "0.5 0 4\n0 0.5 3\n0 0 1\n");  // 166 degrees across
  status = loadStatus();
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {intrinsics.string(), "field of view"});
  writeText("camera-intrinsics.txt", "10 0 40\n0 10 3\n0 0 1\n");
  status = loadStatus();
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {intrinsics.string(), "principal point"});
  writeText("camera-intrinsics.txt", "10 0 4\n0 10 3\n0 0 1\n");  // 44 x 33 degrees
  status = loadStatus();
  EXPECT_TRUE(status.ok()) << status.message();
}

TEST_F(InputFilesDatasetTest, SceneNNIntrinsicsOfThirtyPixelsAreRefusedNamingTheFile) {
  fs::create_directories(dir_ / "image");
  fs::create_directories(dir_ / "depth");
  ASSERT_TRUE(cv::imwrite((dir_ / "image" / "image00001.png").string(),
                          cv::Mat(480, 640, CV_8UC3, cv::Scalar(1, 2, 3))));
  ASSERT_TRUE(cv::imwrite((dir_ / "depth" / "depth00001.png").string(),
                          cv::Mat(480, 640, CV_16UC1, cv::Scalar(1200))));
  writeText("trajectory.log", "0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  // fx = fy = 30 px on 640x480 (169 degrees across) made one keyframe take 40 s and 6.7 GB.
  writeText("asus.ini", "fx 30\nfy 30\ncx 320\ncy 240\n");
  DatasetSource source;
  ASSERT_TRUE(openDatasetSource(dir_.string(), "scenenn", &source).ok());
  RgbdFrame frame;
  Status status = source.load(1, &frame);
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {(dir_ / "asus.ini").string(), "field of view", "169"});
  writeText("asus.ini", "fx 544.47329\nfy 544.47329\ncx 320\ncy 240\n");
  ASSERT_TRUE(openDatasetSource(dir_.string(), "scenenn", &source).ok());
  status = source.load(1, &frame);
  EXPECT_TRUE(status.ok()) << status.message();
}

TEST_F(InputFilesDatasetTest, HugeGravityIsRefusedNotSilentlyEstimated) {
  writeSevenScenes();
  for (const char* gravity : {"0 0 1e308\n", "1e308 1e308 1e308\n", "0 -9.81e7 0\n"}) {
    writeText("gravity-direction.txt", gravity);
    SevenScenesDataset dataset;
    const Status status = SevenScenesDataset::open(dir_.string(), &dataset);
    ASSERT_FALSE(status.ok()) << gravity;
    expectContains(status.message(), {"gravity-direction.txt", "out of range", "estimate"});
    DatasetSource source;
    EXPECT_FALSE(openDatasetSource(dir_.string(), "auto", &source).ok()) << gravity;
  }
  writeText("gravity-direction.txt", "0 0 1e308\n");
  SevenScenesDataset dataset;
  EXPECT_NE(SevenScenesDataset::open(dir_.string(), &dataset).message().find("1e+308"),
            std::string::npos);
  // Large but sane units (mm/s^2) still work.
  writeText("gravity-direction.txt", "0 0 -9810\n");
  ASSERT_TRUE(SevenScenesDataset::open(dir_.string(), &dataset).ok());
  ASSERT_TRUE(dataset.hasGravity());
  EXPECT_TRUE(dataset.gravityDown_W().isApprox(Eigen::Vector3d(0, 0, -1), 1e-12));
}

// ---- Detection files

class InputFilesDetectionsTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::freshTestDir("mvod_input_detections"); }
  void TearDown() override { fs::remove_all(dir_); }

  Status detect(const cv::Size& image_size, std::vector<Detection2D>* detections,
                std::vector<std::string>* warnings, int max_detections = 100) {
    FileInstanceSegmenter::Config config;
    config.max_detections = max_detections;
    FileInstanceSegmenter segmenter(dir_.string(), config);
    const cv::Mat image(image_size, CV_8UC3, cv::Scalar(0, 0, 0));
    return segmenter.detect(image, "frame-000010", detections, warnings);
  }

  fs::path dir_;
};

TEST_F(InputFilesDetectionsTest, FolderAsFrameJsonIsAnErrorNotAnException) {
  fs::create_directories(dir_ / "frame-000010.json");
  std::vector<Detection2D> detections(1);
  Status status;
  EXPECT_NO_THROW(status = detect(cv::Size(32, 24), &detections, nullptr));
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {(dir_ / "frame-000010.json").string(), "not a regular file"});
  EXPECT_TRUE(detections.empty());
}

TEST_F(InputFilesDetectionsTest, TooManyDetectionsAreCappedToTheHighestScores) {
  // 5000 box detections (a 5 MB-class file) on a 640x480 image: uncapped, each would cost a
  // full-image mask (1.5 GB in all).
  std::string text = "[";
  const int kCount = 5000;
  for (int i = 0; i < kCount; ++i) {
    const double score = i == 4321 ? 0.9995 : (i % 1000) / 1000.0;  // one best score
    char entry[160];
    std::snprintf(entry, sizeof(entry),
                  "%s{\"class_name\": \"chair\", \"score\": %.4f, \"box\": [%d, %d, %d, %d]}",
                  i ? ",\n" : "", score, i % 600, i % 440, i % 600 + 30, i % 440 + 40);
    text += entry;
  }
  std::ofstream(dir_ / "frame-000010.json") << text << "]\n";

  std::vector<Detection2D> detections;
  std::vector<std::string> warnings;
  ASSERT_TRUE(detect(cv::Size(640, 480), &detections, &warnings).ok());
  ASSERT_EQ(detections.size(), 100u);
  for (const Detection2D& d : detections) EXPECT_GE(d.score, 0.97f);  // the 100 highest scores
  EXPECT_TRUE(std::any_of(detections.begin(), detections.end(),
                          [](const Detection2D& d) { return d.score > 0.999f; }));
  ASSERT_EQ(warnings.size(), 1u);
  expectContains(warnings[0], {(dir_ / "frame-000010.json").string(), "5000", "max_detections 100",
                               "dropped 4900"});

  // Fewer than the cap: all kept, in the file's order, no warning.
  warnings.clear();
  std::ofstream(dir_ / "frame-000010.json")
      << "[{\"class_name\": \"cup\", \"score\": 0.3, \"box\": [0, 0, 4, 4]},"
         " {\"class_name\": \"tv\", \"score\": 0.9, \"box\": [4, 4, 8, 8]},"
         " {\"class_name\": \"chair\", \"score\": 0.6, \"box\": [1, 1, 8, 8]}]";
  ASSERT_TRUE(detect(cv::Size(32, 24), &detections, &warnings).ok());
  ASSERT_EQ(detections.size(), 3u);
  EXPECT_TRUE(warnings.empty());
  EXPECT_EQ(detections[0].class_name, "cup");
  // max_detections 2: the two highest scores, still in the file's order.
  ASSERT_TRUE(detect(cv::Size(32, 24), &detections, &warnings, 2).ok());
  ASSERT_EQ(detections.size(), 2u);
  EXPECT_EQ(detections[0].class_name, "tv");
  EXPECT_EQ(detections[1].class_name, "chair");
  ASSERT_EQ(warnings.size(), 1u);
  expectContains(warnings[0], {"max_detections 2", "dropped 1"});
  // An invalid cap is an error.
  EXPECT_FALSE(detect(cv::Size(32, 24), &detections, &warnings, 0).ok());
}

TEST_F(InputFilesDetectionsTest, ScoresThatAreNotProbabilitiesAreDroppedWithAWarning) {
  std::ofstream(dir_ / "frame-000010.json")
      << "[{\"class_name\": \"cup\", \"score\": 5, \"box\": [0, 0, 4, 4]},\n"
         " {\"class_name\": \"cup\", \"score\": 1e30, \"box\": [0, 0, 4, 4]},\n"
         " {\"class_name\": \"cup\", \"score\": -0.5, \"box\": [0, 0, 4, 4]},\n"
         " {\"class_name\": \"cup\", \"score\": 0.75, \"box\": [0, 0, 4, 4]}]\n";
  std::vector<Detection2D> detections;
  std::vector<std::string> warnings;
  ASSERT_TRUE(detect(cv::Size(32, 24), &detections, &warnings).ok());
  ASSERT_EQ(detections.size(), 1u);
  EXPECT_FLOAT_EQ(detections[0].score, 0.75f);
  ASSERT_EQ(warnings.size(), 3u);
  const std::string path = (dir_ / "frame-000010.json").string();
  expectContains(warnings[0], {path, "entry 0", "\"score\" 5 ", "[0, 1]", "percentage"});
  expectContains(warnings[1], {path, "entry 1", "1e+30"});
  expectContains(warnings[2], {path, "entry 2", "-0.5"});
}

TEST_F(InputFilesDetectionsTest, MaskBombIsRefusedBeforeDecoding) {
  writeBytes(dir_ / "bomb.png", blackPng(20000, 20000));
  std::ofstream(dir_ / "frame-000010.json")
      << "[{\"class_name\": \"cup\", \"score\": 0.9, \"mask\": \"bomb.png\"},\n"
         " {\"class_name\": \"tv\", \"score\": 0.8, \"box\": [0, 0, 4, 4]}]\n";
  std::vector<Detection2D> detections;
  std::vector<std::string> warnings;
  ASSERT_TRUE(detect(cv::Size(32, 24), &detections, &warnings).ok());
  ASSERT_EQ(detections.size(), 1u);
  EXPECT_EQ(detections[0].class_name, "tv");
  ASSERT_EQ(warnings.size(), 1u);
  expectContains(warnings[0], {"entry 0", "bomb.png", "20000x20000", "32x24", "not decoded"});
}

TEST_F(InputFilesDetectionsTest, ParseDetectionsFromBytesNeverThrows) {
  std::vector<Detection2D> detections;
  std::vector<std::string> warnings;
  FileInstanceSegmenter::Config config;
  for (const std::string& text :
       {std::string("[[[[[[[[[["), std::string("\xff\xfe", 2), std::string("[{\"score\": 1e999}]"),
        std::string("[{\"class_name\": \"cup\", \"score\": 0.5, \"box\": [0, 0, 1e308, 4]}]")}) {
    Status status;
    EXPECT_NO_THROW(
        status = FileInstanceSegmenter::parseDetections(
            text, "bytes.json", dir_.string(), cv::Size(32, 24), config, &detections, &warnings));
    EXPECT_TRUE(detections.empty()) << text;
  }
}

// ---- Map files

// Found by test/fuzz/fuzz_map_json: an object with an evidence grid but no voxels loaded with its
// voxel size, saved without "evidence", and reloaded with none: the map did not round-trip.
TEST(InputFilesMapTest, EvidenceWithoutVoxelsRoundTrips) {
  MapObject object;
  object.id = 4;
  object.class_id = 56;
  object.class_name = "chair";
  object.probability = 0.5;
  object.observations = 1;
  object.box.size_m = Eigen::Vector3d(0.5, 0.5, 0.9);
  std::string text = objectsToJson({object}, MapSummary(), true);
  const std::string points = "\"points\":[]";
  const size_t at = text.find(points);
  ASSERT_NE(at, std::string::npos) << text;
  text.insert(at, "\"evidence\":{\"voxel_size_m\":0.02,\"voxels\":[]},");

  std::vector<MapObject> loaded, reloaded;
  MapSummary summary, reloaded_summary;
  ASSERT_TRUE(objectsFromJson(text, &loaded, &summary).ok());
  const std::string saved = objectsToJson(loaded, summary, true);
  ASSERT_TRUE(objectsFromJson(saved, &reloaded, &reloaded_summary).ok());
  ASSERT_EQ(loaded.size(), 1u);
  ASSERT_EQ(reloaded.size(), 1u);
  EXPECT_TRUE(loaded[0].evidence.empty());
  EXPECT_EQ(loaded[0].evidence_voxel_size_m, reloaded[0].evidence_voxel_size_m);
  EXPECT_EQ(objectsToJson(reloaded, reloaded_summary, true), saved);
}

// nlohmann's get<long long>() of an unsigned 2^64 - 1 is -1: such a class_id loaded as -1, and
// such a voxel index as -1.
TEST(InputFilesMapTest, HugeUnsignedIntegersAreRefusedNotWrapped) {
  MapObject object;
  object.id = 4;
  object.class_id = 56;
  object.class_name = "chair";
  object.points_W = {Eigen::Vector3f(1.0f, 2.0f, 0.5f)};
  object.evidence_voxel_size_m = 0.02;
  object.evidence[packVoxel(Eigen::Vector3i(1, 2, 3))] = VoxelEvidence{2, 1};
  const std::string text = objectsToJson({object}, MapSummary(), true);
  std::vector<MapObject> loaded;
  ASSERT_TRUE(objectsFromJson(text, &loaded, nullptr).ok());

  const auto replaced = [&text](const std::string& from, const std::string& to) {
    std::string changed = text;
    const size_t at = changed.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) changed.replace(at, from.size(), to);
    return changed;
  };
  Status status = objectsFromJson(replaced("\"class_id\":56", "\"class_id\":18446744073709551615"),
                                  &loaded, nullptr);
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {"class_id", "out of range"});
  status =
      objectsFromJson(replaced("[1,2,3,2,1]", "[18446744073709551615,2,3,2,1]"), &loaded, nullptr);
  ASSERT_FALSE(status.ok());
  expectContains(status.message(), {"evidence", "voxels"});
}

}  // namespace
}  // namespace mvod
