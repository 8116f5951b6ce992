#include "multiview_object_detection/ros/keyframe_worker.h"

#include <malloc.h>
#include <ros/console.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <utility>

#include "multiview_object_detection/pipeline/utils/stopwatch.h"
#include "multiview_object_detection/ros/throttled_log.h"

// KeyframeWorker, part 1: the queue, the worker thread and one keyframe. Parts 2 and 3:
// keyframe_worker_changes.cpp (pose corrections, reconfigure), keyframe_worker_map.cpp (refinement,
// the map for the services).

namespace mvod {
namespace {

using Clock = StopwatchClock;

}  // namespace

KeyframeWorker::KeyframeWorker(const ClassPriors& priors,
                               std::unique_ptr<InstanceSegmenter> segmenter,
                               bool segmenter_injected, const RgbdTopics& topics,
                               RuntimeConfig* config, const tf2_ros::Buffer& tf_buffer,
                               DetectionsBuffer* detections, ObjectDetectionPublishers* publishers,
                               SharedStatistics* stats)
    : topics_(topics),
      config_(config),
      tf_buffer_(tf_buffer),
      detections_(detections),
      publishers_(publishers),
      stats_(stats),
      max_queue_size_(config->get().processing_queue_size),
      max_queue_bytes_(config->get().processing_queue_max_mb * 1024.0 * 1024.0),
      mapper_(std::make_unique<ObjectMapper>(config->get().mapperConfig(), priors)),
      segmenter_(std::move(segmenter)),
      segmenter_injected_(segmenter_injected) {
  mapper_->setCancelFlag(&cancel_);
  updateSnapshotLocked();  // no other thread yet
}

KeyframeWorker::~KeyframeWorker() { stop(); }

void KeyframeWorker::start() { thread_ = std::thread(&KeyframeWorker::workerLoop, this); }

void KeyframeWorker::stop() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
  }
  queue_cv_.notify_all();
  if (detections_) detections_->wakeWaiting();
  if (thread_.joinable()) thread_.join();
}

// ---------------------------------------------------------------------------------------------
// Queue

namespace {

// What a queued keyframe holds: its images (the camera infos are small).
std::size_t jobBytes(const KeyframeJob& job) {
  return (job.msgs.color ? job.msgs.color->data.size() : 0) +
         (job.msgs.depth ? job.msgs.depth->data.size() : 0);
}

double toMb(std::size_t bytes) { return static_cast<double>(bytes) / (1024.0 * 1024.0); }

}  // namespace

void KeyframeWorker::enqueue(KeyframeJob job) {
  int dropped_total = 0;
  std::string dropped_what;
  const char* bound = "";
  int queue_length = 0;
  double queue_mb = 0.0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    queue_bytes_ += jobBytes(job);
    queue_.push_back(std::move(job));
    // Full by count, or by memory (the newest is always kept).
    while (static_cast<int>(queue_.size()) > max_queue_size_ ||
           (queue_.size() > 1 && static_cast<double>(queue_bytes_) > max_queue_bytes_)) {
      bound = static_cast<int>(queue_.size()) > max_queue_size_ ? "processing_queue_size"
                                                                : "processing_queue_max_mb";
      dropped_what = describeInput(topics_.color, queue_.front().msgs.color->header);
      queue_bytes_ -= jobBytes(queue_.front());
      queue_.pop_front();
      dropped_total = stats_->update(
          [](ObjectDetectionStatistics& stats) { return ++stats.keyframes_dropped; });
    }
    queue_length = static_cast<int>(queue_.size());
    queue_mb = toMb(queue_bytes_);
    // Under the queue's lock, like the worker's update when it takes a job: set after the lock, a
    // length could overwrite the worker's newer one (a queue of 1 reported for an empty queue).
    stats_->update([queue_length, queue_mb](ObjectDetectionStatistics& stats) {
      ++stats.keyframes_selected;
      stats.queue_length = queue_length;
      stats.queue_mb = queue_mb;
    });
  }
  queue_cv_.notify_one();
  if (!dropped_what.empty()) {
    ROS_WARN_THROTTLE(kLogThrottlePeriodS,
                      "processing queue full (%s; %d keyframes, %.0f MB of images): dropped the "
                      "oldest keyframe %s; %d keyframes dropped so far (processing is slower than "
                      "the keyframe rate)",
                      bound, queue_length, queue_mb, dropped_what.c_str(), dropped_total);
  }
}

void KeyframeWorker::clearQueue() {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  queue_.clear();
  queue_bytes_ = 0;
  pending_corrections_.clear();
  stats_->update([](ObjectDetectionStatistics& stats) {
    stats.queue_length = 0;
    stats.queue_mb = 0.0;
  });
}

void KeyframeWorker::cancelCurrent() { cancel_ = true; }

void KeyframeWorker::stopNow() {
  shut_down_requested_ = true;
  size_t dropped = 0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    dropped = queue_.size();
    queue_.clear();
    queue_bytes_ = 0;
  }
  if (dropped > 0) {
    ROS_INFO("shutdown: %zu queued keyframe(s) dropped; the map is the last processed keyframe's",
             dropped);
  }
  cancelCurrent();
  stop();
}

void KeyframeWorker::enqueueCorrections(std::vector<PoseCorrection> corrections) {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    for (const PoseCorrection& correction : corrections) {
      pending_corrections_[correction.stamp_s] = correction;
    }
  }
  queue_cv_.notify_one();
}

void KeyframeWorker::workerLoop() {
  while (true) {
    KeyframeJob job;
    bool have_job = false;
    bool drained = false;  // the queue is empty behind this job
    std::vector<PoseCorrection> corrections;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock,
                     [this] { return stop_ || !queue_.empty() || !pending_corrections_.empty(); });
      if (queue_.empty() && pending_corrections_.empty()) return;  // stopping and nothing left
      // Corrections first: the keyframes they name are in the map already.
      for (auto& entry : pending_corrections_) corrections.push_back(entry.second);
      pending_corrections_.clear();
      if (!queue_.empty()) {
        queue_bytes_ -= jobBytes(queue_.front());
        job = std::move(queue_.front());
        queue_.pop_front();
        have_job = true;
      }
      const int queue_length = static_cast<int>(queue_.size());
      drained = queue_length == 0;
      const double queue_mb = toMb(queue_bytes_);
      stats_->update([queue_length, queue_mb](ObjectDetectionStatistics& stats) {
        stats.queue_length = queue_length;
        stats.queue_mb = queue_mb;
      });
    }
    if (!corrections.empty()) {
      try {
        applyCorrections(std::move(corrections));
      } catch (const std::exception& e) {
        errorThrottled(std::string("keyframe pose correction failed with an exception: ") +
                       e.what());
        stats_->update([](ObjectDetectionStatistics& stats) { ++stats.callback_exceptions; });
      } catch (...) {
        errorThrottled("keyframe pose correction failed with an unknown exception");
        stats_->update([](ObjectDetectionStatistics& stats) { ++stats.callback_exceptions; });
      }
    }
    if (!have_job) continue;
    // A cancel meant for the keyframe before (a ~reset after it ended) is not this one's.
    if (!shut_down_requested_) cancel_ = false;
    try {
      processKeyframe(job);
    } catch (const std::exception& e) {
      // Nothing may take the node down; a bug in a stage costs one keyframe.
      errorThrottled("keyframe " + describeInput(topics_.color, job.msgs.color->header) +
                     ": processing failed with an exception: " + e.what());
      stats_->update([](ObjectDetectionStatistics& stats) {
        ++stats.keyframes_failed;
        ++stats.callback_exceptions;
      });
    } catch (...) {
      errorThrottled("keyframe " + describeInput(topics_.color, job.msgs.color->header) +
                     ": processing failed with an unknown exception");
      stats_->update([](ObjectDetectionStatistics& stats) {
        ++stats.keyframes_failed;
        ++stats.callback_exceptions;
      });
    }
    if (drained) {
      // A backlog worked off: the memory its images and clouds took goes back to the system
      // (glibc keeps freed memory in its arenas otherwise, and the node's RSS stays at its peak).
      job = KeyframeJob();
      ::malloc_trim(0);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// One keyframe

bool KeyframeWorker::updateGravityFromTf(const std::string& what) {
  const RuntimeConfig::Config config = config_->get();
  const std::string& world_frame = config.world_frame;
  const std::string& gravity_frame = config.gravity_frame;
  std::string tf_error;
  Eigen::Isometry3d T_W_G;
  Status valid = Status::Error("no transform");
  if (tf_buffer_.canTransform(world_frame, gravity_frame, ros::Time(0), &tf_error)) {
    try {
      valid = transformFromMsg(
          tf_buffer_.lookupTransform(world_frame, gravity_frame, ros::Time(0)).transform, &T_W_G);
      if (!valid) tf_error = valid.message();
    } catch (const tf2::TransformException& e) {
      tf_error = e.what();
    }
  }
  if (!valid) {
    warnThrottled(what + " skipped: waiting for gravity (gravity_source tf): no TF '" +
                  world_frame + "' <- '" + gravity_frame + "': " + tf_error);
    return false;
  }
  // Gravity points along -z of gravity_frame (REP 103: z up).
  const Eigen::Vector3d gravity_down_W = -T_W_G.linear().col(2);
  std::lock_guard<std::timed_mutex> lock(mapper_mutex_);
  ObjectMapper::Config mapper_config = mapper_->config();
  mapper_config.gravity_down_W = gravity_down_W;
  const Status updated = mapper_->updateConfig(mapper_config);
  if (!updated) {
    errorThrottled("gravity from TF refused: " + updated.message());
    return false;
  }
  gravity_from_tf_known_ = true;
  ROS_INFO("gravity from TF '%s' <- '%s': down = [%.3f, %.3f, %.3f] in %s", world_frame.c_str(),
           gravity_frame.c_str(), gravity_down_W.x(), gravity_down_W.y(), gravity_down_W.z(),
           world_frame.c_str());
  return true;
}

void KeyframeWorker::capDetections(int max_detections, const std::string& what,
                                   std::vector<Detection2D>* detections) {
  const size_t max = static_cast<size_t>(std::max(1, max_detections));
  if (detections->size() <= max) return;
  const size_t dropped = detections->size() - max;
  warnThrottled(what + ": " + std::to_string(detections->size()) + " detections; only the " +
                std::to_string(max) + " highest-scoring are used (max_detections_per_frame)");
  std::vector<size_t> order(detections->size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [detections](size_t a, size_t b) {
    return (*detections)[a].score > (*detections)[b].score;
  });
  order.resize(max);
  std::sort(order.begin(), order.end());  // the detector's order
  std::vector<Detection2D> kept;
  kept.reserve(max);
  for (const size_t i : order) kept.push_back(std::move((*detections)[i]));
  *detections = std::move(kept);
  stats_->update([dropped](ObjectDetectionStatistics& stats) {
    stats.detections_capped += static_cast<int>(dropped);
  });
}

void KeyframeWorker::processKeyframe(const KeyframeJob& job) {
  const std_msgs::Header& header = job.msgs.color->header;
  const std::string what = "keyframe " + describeInput(topics_.color, header);
  auto failed = [this](const std::string& text) {
    errorThrottled(text);
    stats_->update([](ObjectDetectionStatistics& stats) { ++stats.keyframes_failed; });
  };
  applyPendingReconfigure();
  const RuntimeConfig::Config config = config_->get();

  if (config.gravity_source == "tf" && !gravity_from_tf_known_ && !updateGravityFromTf(what)) {
    stats_->update([](ObjectDetectionStatistics& stats) { stats.waiting_for_gravity = true; });
    return;
  }

  RgbdFrame frame;
  const Status converted = rgbdFrameFromMsgs(job.msgs, topics_, job.T_W_C, job.T_C_D, &frame);
  if (!converted) {
    failed(what + " skipped: " + converted.message());
    return;
  }
  frame.index = job.index;

  // Sec. 3.1: instances in the colour image.
  std::vector<Detection2D> detections;
  double detection_ms = 0.0;
  if (config.detector == "topic") {
    if (!detections_->waitFor(job, config.detections_max_age_s, frame.color_bgr.size(), what,
                              static_cast<size_t>(config.max_detections_per_frame), &detections)) {
      stats_->update([](ObjectDetectionStatistics& stats) { ++stats.keyframes_failed; });
      return;
    }
  } else {
    const Clock::time_point start = Clock::now();
    std::vector<std::string> warnings;
    const Status detected = segmenter_->detect(frame.color_bgr, frame.name, &detections, &warnings);
    detection_ms = msSince(start);
    for (const std::string& warning : warnings) warnThrottled(what + ": " + warning);
    if (!detected) {
      failed(what + " skipped: detector " + segmenter_->name() + ": " + detected.message());
      return;
    }
  }
  // score_threshold may have been raised at run time; external detectors are held to it too.
  const float score_threshold = config.segmenterOptions().score_threshold;
  detections.erase(std::remove_if(detections.begin(), detections.end(),
                                  [score_threshold](const Detection2D& d) {
                                    return !(d.score >= score_threshold);
                                  }),
                   detections.end());
  capDetections(config.max_detections_per_frame, what, &detections);

  publishers_->publishDetectionImage(frame.color_bgr, detections, header);

  KeyframeReport report;
  Status processed;
  {
    std::lock_guard<std::timed_mutex> lock(mapper_mutex_);
    processed = mapper_->processKeyframe(frame, detections, &report);
    removed_gone_ += static_cast<int>(report.removed.size());
    if (processed && config.refine_every_n_keyframes > 0 &&
        mapper_->keyframesProcessed() % config.refine_every_n_keyframes == 0) {
      refineLocked("every " + std::to_string(config.refine_every_n_keyframes) + " keyframes");
    }
    if (processed) updateSnapshotLocked();
  }
  if (!processed) {
    if (cancel_.load()) {
      ROS_INFO("%s: cancelled (%s); nothing of it is in the map", what.c_str(),
               shut_down_requested_.load() ? "shutdown" : "~reset");
      stats_->update([](ObjectDetectionStatistics& stats) { ++stats.keyframes_cancelled; });
      return;
    }
    failed(what + " skipped: " + processed.message());
    return;
  }
  for (const std::string& warning : report.warnings) warnThrottled(warning);
  ROS_DEBUG("%s: %d detections, %d above lambda, %d boxes, %d inserted, %d fused, %.1f ms",
            what.c_str(), report.detections, report.above_threshold, report.with_box,
            report.inserted, report.fused, report.times.total_ms);
  if (!report.removed.empty()) {
    const ExistenceModel existence(mapper_->config().database.existence);
    std::vector<std::string> reasons;
    for (const MapObject& object : report.removed) {
      reasons.push_back(existence.goneReason(object.existence));
      ROS_INFO("%s: %s #%d gone: %s", what.c_str(), object.class_name.c_str(), object.id,
               reasons.back().c_str());
    }
    publishers_->publishRemoved(report.removed, reasons, snapshot()->T_W_O, header.stamp);
  }
  stats_->update([&report, detection_ms](ObjectDetectionStatistics& stats) {
    ++stats.keyframes_processed;
    if (report.depth_fault) ++stats.keyframes_faulty;
    stats.removed_gone += static_cast<int>(report.removed.size());
    stats.waiting_for_gravity = report.waiting_for_gravity;
    stats.detection_ms = detection_ms;
    stats.stage_times = report.times;
  });
  publishMap(header.stamp);
  recordTimes(msSince(job.received), detection_ms, report.times.total_ms);
}

namespace {

// Adds `value_ms` to the last 100 and returns their median.
double pushMedian(std::deque<double>* recent_ms, double value_ms) {
  recent_ms->push_back(value_ms);
  if (recent_ms->size() > 100) recent_ms->pop_front();
  std::vector<double> sorted(recent_ms->begin(), recent_ms->end());
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  return sorted[sorted.size() / 2];
}

}  // namespace

void KeyframeWorker::recordTimes(double latency_ms, double detection_ms, double geometry_ms) {
  const double latency_median_ms = pushMedian(&latencies_ms_, latency_ms);
  const double detection_median_ms = pushMedian(&detection_times_ms_, detection_ms);
  const double geometry_median_ms = pushMedian(&geometry_times_ms_, geometry_ms);
  stats_->update([&](ObjectDetectionStatistics& stats) {
    stats.latency_ms = latency_ms;
    stats.latency_median_ms = latency_median_ms;
    stats.detection_median_ms = detection_median_ms;
    stats.keyframe_total_median_ms = geometry_median_ms;
  });
}

}  // namespace mvod
