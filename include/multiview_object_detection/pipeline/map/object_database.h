// Sec. 3.4: the object database - insert (Eq. 5), same-class nearest-centre fusion (Eq. 6), fused
// clouds re-processed (Eq. 7) and probabilities averaged (Eq. 8).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/map/amodal_completion.h"
#include "multiview_object_detection/pipeline/map/depth_view.h"
#include "multiview_object_detection/pipeline/map/evidence_map.h"
#include "multiview_object_detection/pipeline/map/existence.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

// Evidence fusion: the voxels a view votes on, on a grid of voxel_size_m. They depend on the view
// only, so the single-view stage (in parallel) computes them and the ordered fusion does not.
struct FusionKeys {
  double voxel_size_m = 0.0;
  std::vector<std::int64_t> cut;      // the voxels of the cut (segment_W), ascending, each once
  std::vector<std::int64_t> outside;  // the voxels of seen_W not in the cut, ascending, each once
};
// Built from the cut and the points seen around it (ObjectObservation::segment_W and seen_W).
FusionKeys makeFusionKeys(const PointCloud& segment_W, const PointCloud& seen_W,
                          double voxel_size_m);

// An object detected in one keyframe, after extraction, filtering, LCCP and box estimation.
struct ObjectObservation {
  int class_id = -1;
  std::string class_name;
  double probability = 0.0;  // ψ
  PointCloud points_W;       // filtered object cloud before LCCP (Eq. 7 fuses these)
  PointCloud segment_W;      // the cut: LCCP's largest segment (Eq. 2) or the selected segments
  // Evidence fusion: surface normals of segment_W (one per point, unit, turned towards the camera
  // that saw them; NaN where none was estimated). Empty: none; the fused box then estimates them.
  std::vector<Eigen::Vector3f> segment_normals_W;
  // Evidence fusion: the view's surface points around the cut (in it or not). Voxels of these that
  // are not in the cut are votes against the object there.
  PointCloud seen_W;
  // Evidence fusion: segment_W's and seen_W's voxels (makeFusionKeys); null, or on another grid
  // than the database's: fuseOrInsert computes them.
  std::shared_ptr<const FusionKeys> fusion_keys;
  // Evidence fusion: the keyframe's depth (shared by its detections); null: none.
  std::shared_ptr<const DepthView> depth_view;
  OrientedBox box;       // from segment_W (Eq. 4)
  double yaw_rad = 0.0;  // yaw of box column 0 about gravity (GravityFrame::yawOf)
  int keyframe = 0;
  double stamp_s = 0.0;
};

struct MapObject {
  int id = 0;  // α, never reused
  int class_id = -1;
  std::string class_name;
  double probability = 0.0;  // Eq. 8 running value
  int observations = 0;
  PointCloud points_W;  // fused cloud, voxelised (bounded memory)
  PointCloud
      segment_W;  // paper: largest LCCP segment of the fused cloud; evidence: supported voxels
  EvidenceMap evidence;                // evidence fusion only (key: voxelKey on the fusion grid)
  double evidence_voxel_size_m = 0.0;  // the grid of `evidence` (0: none yet)
  // Evidence fusion: summed probability per class of the detections fused here; class_name is the
  // class with the largest sum (a chair that the detector sometimes calls a couch stays a chair).
  std::map<std::string, double> class_scores;
  OrientedBox box;
  double yaw_rad = 0.0;
  // Amodal completion (evidence fusion, classes with ClassPrior::amodal_depth_m): what the views
  // saw of the cells beside a thin box, and whether `box` was extended into its hidden side.
  FreeSpaceMap free_space;
  double free_space_cell_m = 0.0;  // the grid of `free_space` (0: none yet)
  bool box_completed = false;
  // With box_completed: the box of what the views saw, before completion. Eq. 6 matches new
  // detections (which see what the earlier views saw) against it, not against the completed box.
  OrientedBox observed_box;
  const OrientedBox& seenBox() const { return box_completed ? observed_box : box; }
  int first_keyframe = 0;
  int last_keyframe = 0;
  double first_seen_s = 0.0;
  double last_seen_s = 0.0;
  // Whether it is still there: the keyframes' votes (existence.h).
  ExistenceEvidence existence;
  // Evidence fusion: the boxes of the views fused here (ObjectObservation::box), the last
  // kMaxViewBoxes of them; the box is their consensus where they agree (view_consensus.h).
  std::vector<OrientedBox> view_boxes;
};

// MapObject::view_boxes keeps this many of the latest views.
constexpr std::size_t kMaxViewBoxes = 128;

// Re-runs filter + LCCP + box on a fused world-frame cloud (Eq. 7). Returns false when nothing
// usable is left, in which case the object keeps its previous segment and box.
// normals_W: evidence fusion's per-voxel normals of points_W (any number; empty: none kept, e.g.
// the paper's fusion or a map saved before normals were kept). class_name: the object's class
// after this fusion (class priors such as on_floor apply to the box).
using FusedCloudProcessor =
    std::function<bool(const std::string& class_name, const PointCloud& points_W,
                       const std::vector<Eigen::Vector3f>& normals_W, PointCloud* segment_W,
                       OrientedBox* box, double* yaw_rad)>;

// Object ids lie in [0, kMaxObjectId]: far more than any map holds, and far enough from INT_MAX
// that the next id never overflows.
constexpr int kMaxObjectId = 1000000000;

class ObjectDatabase {
 public:
  struct Config {
    // Fused clouds are voxelised at this size after each fusion so memory stays bounded (m).
    double fusion_voxel_size_m = 0.01;
    // Objects inserted in the current keyframe are not fusion candidates for other detections of
    // the same keyframe (Sec. 3.4.1: two same-class detections in one image are two objects).
    // Evidence fusion: nor are objects another detection of the keyframe fused into.
    bool no_fusion_within_keyframe = true;
    // Table 2's single-frame baseline: every observation is inserted as a new object, nothing is
    // fused.
    bool disable_fusion = false;
    // paper: Eq. 7 as written, the union of the views' clouds re-filtered, re-segmented and
    // re-boxed. evidence: each voxel counts the views that put it inside their cut and those that
    // saw it but left it out; the box comes from the voxels that are inside at least as often.
    std::string fusion = "evidence";
    // Evidence fusion: a detection whose cut lies at least this much (share of its voxels) on an
    // object's voted voxels may join it whatever the classes and centres (0 = centres and classes
    // only: Eq. 6's Γ_C, unless the view saw the object apart from its cut; see associate()).
    double min_overlap_to_fuse = 0.5;
    // Evidence fusion, the overlap above with an object of the detection's class: a cut voxel
    // counts as on the object when one of its voted voxels (inside >= outside) lies within this
    // many voxels of it (any of
    // the (2n+1)^3 around it). Views of a thin part from either side (a backrest seen from the
    // front and from behind) fill neighbouring voxels, not the same ones. Objects of other classes
    // match on the voxels themselves (a book on a table stays a book). 0 = the voxels themselves.
    int same_class_overlap_voxels = 1;
    // Evidence fusion: a voxel is supported only when its mean projective signed distance over the
    // views that saw it (ObjectObservation::depth_view) lies within this band of the measured
    // surface: the shell of noise that several views of one surface leave (several centimetres
    // at 3-4 m) thins towards the surface they agree on. Voxels no view measured pass. 0 = off.
    double surface_band_m = 0.02;
    // Evidence fusion: boxes of classes with a known depth (ClassPrior::amodal_depth_m) extended
    // into the side the views never saw through (a chair under a table, only its backrest seen).
    AmodalCompletion::Config amodal;
    // Evidence fusion: an object whose views agree on its extent up to this much on every axis
    // (the union of their cuts against the quartiles of their boxes' ends) is boxed by the views'
    // consensus, not by the union, which the error of the poses between the views widens
    // (view_consensus.h). About the pose error between views of one object. 0 = the union.
    double view_consensus_m = 0.06;
    // Evidence fusion: whether objects are still there, from every keyframe's depth; the gone are
    // removed (ObjectMapper).
    ExistenceModel::Config existence;
    Status isValid() const;
    std::string print() const;
  };

  enum class Decision { kInserted, kFused };
  struct FusionResult {
    Decision decision = Decision::kInserted;
    int object_id = 0;
    double distance_m = 0.0;  // min(d_i) of Eq. 6, infinity when no same-class object exists
  };

  ObjectDatabase() = default;
  ObjectDatabase(const Config& config, const ClassPriors& priors)
      : config_(config), priors_(priors) {}
  const Config& config() const { return config_; }
  // New settings for the next fusions; objects and ids are kept.
  void setConfig(const Config& config) { config_ = config; }
  const ClassPriors& priors() const { return priors_; }
  // The floor's height along gravity's up (amodal completion grounds completed boxes on it); NaN:
  // unknown (the default).
  void setFloorHeight(double floor_height_m) { floor_height_m_ = floor_height_m; }
  // Gravity's up (unit): amodal completion leaves boxes whose third axis is not along it (a box
  // estimated without the gravity constraint). Zero (the default): every box's third axis is up.
  void setGravityUp(const Eigen::Vector3d& up) { gravity_up_ = up; }

  // Eq. 6: nearest same-class object by box-centre distance; fuse if within the class threshold
  // Γ_C, else insert. On fusion the clouds are merged (Eq. 7), voxelised, re-processed by
  // `process`, and the probability becomes mean(ψ_new, ψ_j) (Eq. 8).
  // defer_rebox (evidence fusion only): the votes are counted now, but the supported voxels are
  // boxed (`process`) later, by reboxPending(), once per object however many detections of the
  // keyframe fused into it, and the objects in parallel. Until then the object keeps its previous
  // segment and box (a later detection of the same keyframe is matched against those).
  // object_id: the association decided beforehand (associate()): an object's id to fuse into, or
  // -1 to insert; kAssociateNow (the default) decides here, against the objects no earlier
  // observation of this keyframe took.
  static constexpr int kAssociateNow = -2;
  FusionResult fuseOrInsert(const ObjectObservation& observation,
                            const FusedCloudProcessor& process, bool defer_rebox = false,
                            int object_id = kAssociateNow);
  // One keyframe's observations matched to the objects at once, before any is fused: per
  // observation, the id of the object it joins or -1 (a new object). Evidence fusion: a detection
  // joins an object its cut overlaps (min_overlap_to_fuse), or a same-class object within the
  // class's Γ_C that its view did not see apart from the cut; each object takes at most one
  // detection of a keyframe (two detections in one image are two objects), the pairs of the same
  // class and the largest overlap first. The paper's fusion and disable_fusion: kAssociateNow for
  // each (Eq. 6, one observation after the other).
  std::vector<int> associate(const std::vector<const ObjectObservation*>& observations);
  // Adds the keyframe's signed distances (surface band) to, and boxes the supported voxels of,
  // every object fused with defer_rebox since the last call, on up to `threads` threads (each
  // object is independent: the same result for any thread count). A processor that returns false
  // leaves that object's previous segment and box. Returns how many objects were re-boxed.
  int reboxPending(const FusedCloudProcessor& process, int threads);
  // One keyframe's existence votes (evidence fusion with existence enabled): detected_ids were
  // fused or inserted in this keyframe; every other object is tested against the keyframe's depth
  // (view may be null: only the detections vote). Returns the ids of the objects that are gone
  // (not removed here).
  std::vector<int> updateExistence(const DepthView* view, const std::vector<int>& detected_ids);
  // What the keyframe's depth says of the confirmed objects before it votes
  // (ExistenceModel::DepthCheck).
  ExistenceModel::DepthCheck checkDepth(const DepthView& view) const;
  // Objects waiting for reboxPending().
  const std::vector<int>& pendingRebox() const { return pending_rebox_; }
  // Evidence fusion: one object mapped twice (the refinement's duplicates) becomes one. The votes,
  // signed distances and normals of `from_id` are added to `into_id`'s voxels, with its
  // observations and class scores; the probability becomes the observation-weighted mean; the
  // merged object is boxed (`process`) and `from_id` removed. False (and nothing changes) unless
  // both exist, differ and hold evidence on this database's grid.
  bool mergeInto(int into_id, int from_id, const FusedCloudProcessor& process);

  // A voxel of the object: inside >= 1, inside >= outside and, where views measured it, within
  // surface_band_m of the surface they saw.
  bool isSupported(const VoxelEvidence& e) const;
  // Evidence fusion's supported voxels (centres).
  // normals_W (optional): the supported voxels' normals (normalised sums) where they have one.
  PointCloud supportedVoxels(const MapObject& object,
                             std::vector<Eigen::Vector3f>* normals_W = nullptr) const;
  // The fusion grid's key of a point (voxel_key.h), and a key's voxel centre.
  std::int64_t voxelKey(const Eigen::Vector3f& p_W) const;
  Eigen::Vector3f voxelCentre(std::int64_t key) const;

  const std::map<int, MapObject>& objects() const { return objects_; }
  const MapObject* find(int id) const;
  std::vector<const MapObject*> findByClass(const std::string& class_name) const;
  // `taken`, when given, receives the object (moved out, not copied).
  bool remove(int id, MapObject* taken = nullptr);
  // Removes every object. Ids are still never reused: next_id_ keeps counting.
  void clear();
  // Replaces the content (map loading); next ids continue after the largest loaded id. Refuses
  // (and keeps the content) ids outside [0, kMaxObjectId] or repeated.
  Status setObjects(const std::vector<MapObject>& objects);
  int nextId() const { return next_id_; }
  // Ids below next_id are never given to new objects (a rebuilt map continues its predecessor's).
  void reserveIdsBelow(int next_id) { next_id_ = std::max(next_id_, next_id); }
  size_t size() const { return objects_.size(); }

 private:
  // The per-keyframe step: a new keyframe's detections may fuse into the objects inserted by the
  // previous one (no_fusion_within_keyframe).
  void beginKeyframe(int keyframe);
  bool insertedThisKeyframe(const MapObject& object) const;
  // Evidence fusion: inserted or fused into by an observation of the current keyframe.
  bool takenThisKeyframe(const MapObject& object) const;
  // Evidence fusion's association: an object an observation may join. tier 0: same class, 1:
  // another class (joined by overlap only).
  struct Candidate {
    MapObject* object = nullptr;
    int tier = 0;
    double overlap = 0.0;
    double distance_m = 0.0;
  };
  // The objects the observation may join (not taken this keyframe), best first: same class before
  // other classes, then the largest overlap, then the nearest.
  std::vector<Candidate> candidatesOf(const ObjectObservation& observation, const FusionKeys& keys);
  // Whether the view saw the object apart from the detection: of the object's voted voxels within
  // `reach` voxels of what the view saw, more lie only on the surface around the detection than in
  // its mask (mask: the voxels of its points_W, ascending) or cut, and they are at least a tenth
  // of the object (a book beside the detected book).
  static bool seenApart(const MapObject& object, const std::vector<std::int64_t>& mask,
                        const FusionKeys& keys, int reach);
  // Eq. 6's candidate: the nearest object of the observation's class by box-centre distance (null
  // and infinity when none).
  MapObject* nearestSameClass(const ObjectObservation& observation, double* distance_m);
  // Evidence fusion: the observation's fusion keys on this database's grid.
  std::shared_ptr<const FusionKeys> fusionKeysOf(const ObjectObservation& observation) const;
  // The share of the cut's voxels on the object's voted voxels (or within `reach` voxels of one).
  static double overlapShare(const MapObject& object, const std::vector<std::int64_t>& cut,
                             int reach);
  // The per-observation fusion: one observation into one object. Eq. 8's probability and the
  // observation count and times.
  static void addObservation(const ObjectObservation& observation, MapObject* object);
  // Evidence fusion: the class vote, the view's votes on the object's voxels, then the box now
  // (`process`) or, with defer_rebox, at reboxPending().
  void fuseEvidence(const ObjectObservation& observation, const FusionKeys& keys,
                    const FusedCloudProcessor& process, bool defer_rebox, MapObject* object);
  // Marks an object for reboxPending(), with the keyframe's depth (may be null).
  void deferRebox(const MapObject& object, const std::shared_ptr<const DepthView>& depth_view);
  // The paper's fusion (Eq. 7): the clouds merged and voxelised, the result re-processed.
  void fusePaper(const ObjectObservation& observation, const FusedCloudProcessor& process,
                 MapObject* object) const;
  // A new object from the observation (keys: evidence fusion's, else null); returns its id.
  int insert(const ObjectObservation& observation, const FusionKeys* keys);
  int takeNextId();
  // Boxes an object's supported voxels (`process`) and rebuilds its cloud from its evidence.
  // view: the keyframe's depth (its free space around the object), or null.
  void rebox(MapObject* object, const FusedCloudProcessor& process, const DepthView* view) const;
  // Amodal completion of a freshly estimated box: the view's free space around it counted (view
  // may be null), and the box extended when its counts decide a side.
  void completeBox(MapObject* object, const DepthView* view) const;
  // Evidence fusion: the observation's box among the object's views (at most kMaxViewBoxes).
  static void addViewBox(const OrientedBox& box, MapObject* object);

  Config config_;
  ClassPriors priors_;
  std::map<int, MapObject> objects_;
  double floor_height_m_ = std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3d gravity_up_ = Eigen::Vector3d::Zero();
  int next_id_ = 1;
  int current_keyframe_ = -1;
  std::vector<int> inserted_this_keyframe_;
  std::vector<int> fused_this_keyframe_;  // evidence fusion: fused into this keyframe
  std::vector<int> pending_rebox_;        // ascending ids
  // Of pending objects: the keyframe whose signed distances reboxPending adds first.
  std::map<int, std::shared_ptr<const DepthView>> pending_depth_views_;
};

}  // namespace mvod
