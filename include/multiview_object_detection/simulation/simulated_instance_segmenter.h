// A detector simulated from ground truth: per-frame instance label images of a SceneNN-layout
// sequence become Detection2D lists with the failure modes a real Mask R-CNN shows on SceneNN, the
// ones the paper's 3D stages (filters, LCCP, fusion, refinement) are there to fight: missed
// instances, masks that bleed into the background, object parts labelled as another class, class
// confusions, spread scores (some under λ) and false positives on clutter.
//
// Sequence layout (the <id> folder):
//   <id>/<id>.xml                 SceneNN annotation: <annotation><label id=".." text=".."
//   .../></annotation> <id>/label/labelNNNNN.png     CV_16UC1, pixel = label id of the XML, 0 =
//   nothing; NNNNN 1-based, 5
//                                 digits, the number of image/imageNNNNN.png (frame "image00001")
// A label's class is its text (then its nyu_class) as a COCO name: trailing digits dropped
// ("chair2"), spellings mapped by canonicalClassName ("sofa" -> couch, "table" -> dining table).
// Labels with a COCO class are detected (with failures); the others are clutter, seen only as false
// positives.
//
// Randomness is a splitmix64 stream per (seed, frame number, label id, decision) and plain
// arithmetic (no std:: distributions), so a frame's detections are the same on every platform,
// whichever frames were processed before, and changing one probability does not reshuffle the other
// decisions.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/detection.h"

namespace mvod {

// `from` is detected as `to` with `probability` (per instance and frame).
struct ClassConfusion {
  std::string from;
  std::string to;
  double probability = 0.0;
};

class SimulatedInstanceSegmenter : public InstanceSegmenter {
 public:
  struct Config {
    uint64_t seed = 1;

    // Misses. Always when the visible area is under min_pixels; between min_pixels and
    // small_area_px the miss probability falls linearly from small_miss_probability to
    // miss_probability.
    double miss_probability = 0.1;
    int min_pixels = 300;
    int small_area_px = 1500;
    double small_miss_probability = 0.5;

    // Masks bleeding into the background (and anything else around): with bleed_probability the
    // mask is dilated by an elliptical kernel with random half-axes of min_bleed_px..max_bleed_px
    // (px, each axis drawn). Those pixels' depth is what the 3D filters and LCCP must cut away.
    double bleed_probability = 0.5;
    int min_bleed_px = 2;
    int max_bleed_px = 15;
    // Light boundary jitter: with jitter_probability each boundary pixel within jitter_px of the
    // edge is moved in or out following a smooth random field (cells of jitter_cell_px).
    double jitter_probability = 0.5;
    int jitter_px = 1;
    int jitter_cell_px = 6;

    // Object parts as another class: with part_probability the top, bottom, left or right
    // min_part_fraction..max_part_fraction of the (degraded) mask's extent becomes a separate
    // detection of part_classes[class] with a confused score below the main one; with
    // part_removed_probability it is also cut out of the main mask. Classes not in part_classes
    // have no part detections; parts under min_pixels are not emitted.
    double part_probability = 0.15;
    double part_removed_probability = 0.5;
    double min_part_fraction = 0.3;
    double max_part_fraction = 0.5;
    std::map<std::string, std::string> part_classes = {
        {"chair", "couch"},        {"couch", "chair"}, {"bed", "couch"},
        {"dining table", "chair"}, {"tv", "laptop"},   {"refrigerator", "oven"}};

    // Class confusions of whole instances (COCO names; the probabilities of one `from` sum to <=
    // 1).
    std::vector<ClassConfusion> confusions = {
        {"chair", "couch", 0.1}, {"couch", "chair", 0.1}, {"bed", "couch", 0.05}};

    // False positives on clutter: `from` is a label text (lower case, trailing digits dropped, e.g.
    // "shelf"), `to` the COCO class it is taken for; the clutter's visible mask (bled/jittered like
    // any other) with a confused score. The probabilities of one `from` sum to <= 1.
    std::vector<ClassConfusion> false_positives = {
        {"shelf", "book", 0.05},       {"shelf", "refrigerator", 0.02},
        {"bookshelf", "book", 0.05},   {"cabinet", "refrigerator", 0.03},
        {"desk", "dining table", 0.1}, {"tv stand", "tv", 0.02}};

    // Scores ~ N(mean, stddev) (sum of 12 uniforms), clipped to [min_score, max_score]. "True" =
    // right class; "confused" = confusions, parts and false positives.
    double true_score_mean = 0.85;
    double true_score_stddev = 0.1;
    double confused_score_mean = 0.6;
    double confused_score_stddev = 0.15;
    double min_score = 0.05;
    double max_score = 0.99;

    // Every probability 0, exact scores (true_score_mean), min_pixels 1: each labelled COCO-class
    // instance comes back with its exact visible mask and class.
    static Config perfect();
    // Message naming the first bad field; ok when every value is usable.
    Status isValid() const;
  };

  // Reads <directory>/<id>.xml (id = the folder's name) and checks the config; errors name the
  // file.
  static Status create(const std::string& directory, const Config& config,
                       std::unique_ptr<SimulatedInstanceSegmenter>* segmenter);

  // frame_name ends with the frame number ("image00001" -> label/label00001.png). A missing,
  // unreadable, non-16-bit or wrongly sized label image is an error naming the file (the sequence
  // claims ground truth for every frame); a label id not in the XML is a warning (pixels skipped).
  // Detections are ordered by label id (parts and false positives after their instance) and are not
  // thresholded: λ is the mapper's job.
  Status detect(const cv::Mat& image_bgr, const std::string& frame_name,
                std::vector<Detection2D>* detections,
                std::vector<std::string>* warnings = nullptr) override;
  std::string name() const override { return "simulated"; }

  const Config& config() const { return config_; }
  // Label id -> COCO class ("" = clutter), as read from the XML.
  const std::map<int, std::string>& labelClasses() const { return label_classes_; }

  // The label image of a frame: <directory>/label/labelNNNNN.png.
  std::string labelImagePath(int frame_number) const;

 private:
  SimulatedInstanceSegmenter(std::string directory, Config config);
  // Instance `id` (its pixels' bounding box and count) as the detector reports it, with its
  // failures: appended to detections (then its part detection), or nothing when missed.
  void detectInstance(const cv::Mat& labels, int frame_number, int id, const cv::Rect& box,
                      int count, const std::string& true_class,
                      std::vector<Detection2D>* detections);

  std::string directory_;
  Config config_;
  std::map<int, std::string> label_classes_;  // COCO class, "" = clutter
  std::map<int, std::string> label_texts_;    // normalised text, for false positives
};

}  // namespace mvod
