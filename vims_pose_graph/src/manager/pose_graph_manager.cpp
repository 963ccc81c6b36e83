#include "vims_pose_graph/pose_graph_manager.h"

#include <utility>

#include "pose_graph_manager_core.h"
#include "pose_graph_thread_runner.h"

namespace vims {

namespace {
constexpr const char* kComponent = "pose_graph_manager";

/// Synchronous mode (no runner): runs the event now; asynchronous: queues it.
void runOrQueue(PoseGraphManagerCore& core, std::mutex& state_mutex, PoseGraphThreadRunner* runner,
                PoseGraphEvent event) {
  if (runner == nullptr)
    runEvent(core, state_mutex, event);
  else
    runner->enqueue(std::move(event));
}
}  // namespace

// ---------------------------------------------------------------------------------------------
// Construction
// ---------------------------------------------------------------------------------------------

std::shared_ptr<const BinaryVocabulary> PoseGraphManager::loadVocabulary(const PoseGraphManagerOptions& options,
                                                                         const std::string& package_root) {
  return std::make_shared<const BinaryVocabulary>(
      BinaryVocabulary::load(resolveVocabularyPath(options.vocabularyPath(), package_root)));
}

PoseGraphManager::PoseGraphManager(const PoseGraphManagerOptions& options, const SequenceConfig& sequence,
                                   std::shared_ptr<const BinaryVocabulary> vocabulary, LoggerPtr logger)
    : options_(options),
      mode_(options.modeSettings()),
      logger_(logger ? std::move(logger) : Logger::nullLogger()),
      core_(std::make_unique<PoseGraphManagerCore>(options, sequence, std::move(vocabulary), logger_)) {
  logger_->info(kComponent, VIMS_STR("mode " << toString(options_.mode) << " (descriptor " << toString(mode_.descriptor)
                                             << ", magnetic stage " << (mode_.magnetic_stage ? "on" : "off")
                                             << ", geomagnetic yaw " << (mode_.geomagnetic_yaw ? "on" : "off") << "), "
                                             << (options_.synchronous ? "synchronous" : "worker threads")));
  if (!options_.record_inputs_path.empty()) {
    recorder_ = std::make_unique<InputRecorder>(options_.record_inputs_path);
    logger_->info(kComponent, "recording the inputs to " + options_.record_inputs_path);
  }
  if (!options_.synchronous) runner_ = std::make_unique<PoseGraphThreadRunner>(*core_, state_mutex_, logger_);
}

// The runner's threads stop (and leave the core) before the core goes.
PoseGraphManager::~PoseGraphManager() { runner_.reset(); }

// ---------------------------------------------------------------------------------------------
// Inputs: recorded, then run inline (synchronous) or queued for the processing thread
// ---------------------------------------------------------------------------------------------

void PoseGraphManager::feedKeyframe(const KeyframeData& keyframe) {
  if (recorder_) {
    std::lock_guard<std::mutex> lk(recorder_mutex_);
    recorder_->write(keyframe);
  }
  if (!runner_) {
    runEvent(*core_, state_mutex_, keyframe);
    return;
  }
  KeyframeData copy = keyframe;
  copy.image = keyframe.image.clone();  // the caller may reuse its buffer
  runner_->enqueue(std::move(copy));
}

void PoseGraphManager::feedSignature(const SignatureWindow& window) {
  if (recorder_) {
    std::lock_guard<std::mutex> lk(recorder_mutex_);
    recorder_->write(window);
  }
  runOrQueue(*core_, state_mutex_, runner_.get(), window);
}

void PoseGraphManager::feedGeomagnetic(double t, const Eigen::Vector3d& field_body) {
  if (recorder_) {
    std::lock_guard<std::mutex> lk(recorder_mutex_);
    recorder_->write(t, field_body);
  }
  runOrQueue(*core_, state_mutex_, runner_.get(), GeomagneticMeasurement{t, field_body});
}

void PoseGraphManager::finish() {
  if (recorder_) {
    std::lock_guard<std::mutex> lk(recorder_mutex_);
    recorder_->flush();
  }
  runOrQueue(*core_, state_mutex_, runner_.get(), FinishEvent{});
  waitForIdle();
}

void PoseGraphManager::waitForIdle() const {
  if (runner_) runner_->waitForIdle();
}

// ---------------------------------------------------------------------------------------------
// Map files
// ---------------------------------------------------------------------------------------------

void PoseGraphManager::loadMap(const std::string& path) {
  std::lock_guard<std::mutex> lk(state_mutex_);
  core_->loadMap(path);
}

void PoseGraphManager::saveMap(const std::string& path) const {
  waitForIdle();
  std::lock_guard<std::mutex> lk(state_mutex_);
  core_->saveMap(path);
}

void PoseGraphManager::setMapMode(MapMode mode) {
  // Queued keyframes were fed under the old mode: they are processed under it.
  waitForIdle();
  std::lock_guard<std::mutex> lk(state_mutex_);
  core_->setMapMode(mode);
}

RelocalisationStatus PoseGraphManager::relocalisationStatus() const {
  std::lock_guard<std::mutex> lk(state_mutex_);
  return core_->relocalisationStatus();
}

// ---------------------------------------------------------------------------------------------
// Outputs: copies taken under the map lock
// ---------------------------------------------------------------------------------------------

std::vector<KeyframePose> PoseGraphManager::keyframePoses(bool include_loaded) const {
  std::lock_guard<std::mutex> lk(state_mutex_);
  return core_->keyframePoses(include_loaded);
}

Eigen::Isometry3d PoseGraphManager::T_map_odom() const {
  std::lock_guard<std::mutex> lk(state_mutex_);
  return core_->T_map_odom();
}

Eigen::Isometry3d PoseGraphManager::correctedPose(const Eigen::Isometry3d& T_odom_b) const {
  return T_map_odom() * T_odom_b;
}

std::vector<LoopEdgeInfo> PoseGraphManager::loopEdges() const {
  std::lock_guard<std::mutex> lk(state_mutex_);
  return core_->loopEdges();
}

std::vector<LoopAttempt> PoseGraphManager::loopAttempts() const {
  std::lock_guard<std::mutex> lk(state_mutex_);
  return core_->loopAttempts();
}

std::vector<LoopAttempt> PoseGraphManager::takeNewLoopAttempts() {
  std::lock_guard<std::mutex> lk(state_mutex_);
  return core_->takeNewLoopAttempts();
}

MapContents PoseGraphManager::mapContents() const {
  std::lock_guard<std::mutex> lk(state_mutex_);
  return core_->mapContents();
}

PoseGraphManagerStats PoseGraphManager::stats() const {
  std::lock_guard<std::mutex> lk(state_mutex_);
  return core_->stats();
}

PoseGraphTimings PoseGraphManager::timings(size_t first_solve) const {
  std::lock_guard<std::mutex> lk(state_mutex_);
  return core_->scheduler().timings(first_solve);
}

std::optional<DetectionResult> PoseGraphManager::lastDetection() const {
  std::lock_guard<std::mutex> lk(state_mutex_);
  return core_->lastDetection();
}

void PoseGraphManager::inspectMap(const std::function<void(const MultiScaleMap&)>& f) const {
  std::lock_guard<std::mutex> lk(state_mutex_);
  f(core_->map());
}

}  // namespace vims
