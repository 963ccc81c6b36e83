#include "vims_system/vio_system.h"

#include "vims_system/system_config.h"

namespace vims {

VioSystem::VioSystem(const SequenceConfig& sequence, const SystemConfig& config, LoggerPtr logger)
    : tracker_(sequence.camera, config.tracker, logger), estimator_(sequence, config.estimator, logger) {}

VioOutputs VioSystem::takeOutputs() {
  VioOutputs out;
  for (VioFrameResult& r : estimator_.takeFrameResults()) {
    out.backend_ms.push_back(r.backend_ms);
    if (r.status == VioStatus::kWaitingForImu || r.status == VioStatus::kReset) continue;
    if (!r.T_odom_b_at_stamp.matrix().topRows<3>().allFinite() || !r.v_odom_b.allFinite()) {
      out.non_finite_stamps.push_back(r.t_stamp);
      continue;
    }
    out.poses.push_back(std::move(r));
  }
  out.keyframes = estimator_.takeKeyframes();
  return out;
}

void writeVioTumRow(TumWriter* tum, const VioFrameResult& frame) {
  tum->write(frame.t_stamp, frame.T_odom_b_at_stamp.translation(),
             Eigen::Quaterniond(frame.T_odom_b_at_stamp.linear()));
}

}  // namespace vims
