#include "vims_common/tracked_frame.h"

namespace vims {

const char* frameStatusName(FrameStatus status) {
  switch (status) {
    case FrameStatus::kTracked:
      return "tracked";
    case FrameStatus::kStarted:
      return "started";
    case FrameStatus::kResetOnStamp:
      return "reset_on_stamp";
    case FrameStatus::kResetOnGap:
      return "reset_on_gap";
    case FrameStatus::kBlank:
      return "blank";
    case FrameStatus::kRejectedEmpty:
      return "rejected_empty";
    case FrameStatus::kRejectedType:
      return "rejected_type";
    case FrameStatus::kRejectedSize:
      return "rejected_size";
    case FrameStatus::kRejectedStamp:
      return "rejected_stamp";
  }
  return "?";
}

bool TrackedFrame::accepted() const {
  return status == FrameStatus::kTracked || status == FrameStatus::kStarted || status == FrameStatus::kResetOnStamp ||
         status == FrameStatus::kResetOnGap || status == FrameStatus::kBlank;
}

}  // namespace vims
