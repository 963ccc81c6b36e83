#pragma once
/// @file input_recording.h
/// @brief Records the PoseGraphManager's inputs (keyframes with image and landmarks, signature
/// windows, geomagnetic samples, in feed order) to a file and reads them back, so loop closing
/// can be re-run and diagnosed on the real VIO keyframes of a sequence without re-running the
/// front end and the VIO (vims_pose_graph_replay; docs/pose_graph.md, "Replaying recorded inputs").
///
/// File: magic "VIMSPGIN", u32 version (2; version 1, before several coils, is read too: its
/// signatures are coil 0's), then events until the end of the file, each a u8 kind
/// (1 keyframe, 2 signature, 3 geomagnetic) and its payload, little-endian:
///  - keyframe: t f64, session u32, T_odom_b (t xyz, row-major R) 12 f64, landmarks u32 count x
///    (id u64, p_odom 3 f64, pixel 2 f64, normalized 2 f64), image PNG (u32 size + bytes, 0 = none);
///  - signature: t, t_start, t_end, frequency_hz f64, amplitude_enu 3 f64, geomagnetic_body 3 f64,
///    snr f64, valid u8, flags u32, coil u32 (version 2);
///  - geomagnetic: t f64, field_body 3 f64.

#include <Eigen/Core>
#include <cstdint>
#include <fstream>
#include <string>
#include <variant>

#include "vims_common/keyframe_data.h"
#include "vims_common/magnetic_signature.h"

namespace vims {

struct RecordedGeomagnetic {
  double t = 0.0;
  Eigen::Vector3d field_body = Eigen::Vector3d::Zero();
};

using RecordedInput = std::variant<KeyframeData, SignatureWindow, RecordedGeomagnetic>;

/// Appends inputs to a file (created/truncated on construction). Throws std::runtime_error when
/// the file cannot be written.
class InputRecorder {
 public:
  explicit InputRecorder(const std::string& path);
  void write(const KeyframeData& keyframe);
  void write(const SignatureWindow& window);
  void write(double t, const Eigen::Vector3d& field_body);
  void flush();

 private:
  void check();
  std::string path_;
  std::ofstream out_;
};

/// Reads a recording event by event. Throws std::runtime_error naming the file for a bad magic,
/// version or a truncated/corrupt event.
class InputReader {
 public:
  explicit InputReader(const std::string& path);
  /// False at the end of the file.
  bool next(RecordedInput* input);

 private:
  std::string path_;
  std::ifstream in_;
  uint32_t version_ = 0;
};

}  // namespace vims
