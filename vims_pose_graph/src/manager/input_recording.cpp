#include "vims_pose_graph/input_recording.h"

#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <vector>

#include "vims_pose_graph/magnetic_submap.h"

namespace vims {

namespace {
constexpr char kMagic[8] = {'V', 'I', 'M', 'S', 'P', 'G', 'I', 'N'};
// Version 2: a signature's coil index. Version 3: a keyframe's port depth and camera extrinsic.
constexpr uint32_t kVersion = 3;
constexpr uint8_t kKeyframe = 1, kSignature = 2, kGeomagnetic = 3;
/// Which optional parts a keyframe event carries (version 3).
constexpr uint8_t kHasPortDepth = 1, kHasCameraExtrinsic = 2;
/// Upper bounds that reject a corrupt count before allocating.
constexpr uint32_t kMaxLandmarks = 1000000;
constexpr uint32_t kMaxImageBytes = 256u << 20;

template <typename T>
void put(std::ofstream& out, const T& v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof(T));
}
template <typename T>
void get(std::ifstream& in, T* v, const std::string& path) {
  in.read(reinterpret_cast<char*>(v), sizeof(T));
  if (!in) throw std::runtime_error("input recording " + path + ": truncated event");
}
void putVec(std::ofstream& out, const Eigen::Vector3d& v) {
  for (int i = 0; i < 3; ++i) put(out, v[i]);
}
Eigen::Vector3d getVec(std::ifstream& in, const std::string& path) {
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) get(in, &v[i], path);
  return v;
}
/// A pose as its translation, then its rotation matrix row by row.
void putPose(std::ofstream& out, const Eigen::Isometry3d& T) {
  putVec(out, T.translation());
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) put(out, T.linear()(r, c));
}
Eigen::Isometry3d getPose(std::ifstream& in, const std::string& path) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = getVec(in, path);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) get(in, &T.linear()(r, c), path);
  return T;
}
}  // namespace

InputRecorder::InputRecorder(const std::string& path) : path_(path), out_(path, std::ios::binary | std::ios::trunc) {
  out_.write(kMagic, sizeof(kMagic));
  put(out_, kVersion);
  check();
}

void InputRecorder::check() {
  if (!out_) throw std::runtime_error("input recording " + path_ + ": cannot write");
}

void InputRecorder::write(const KeyframeData& kf) {
  put(out_, kKeyframe);
  put(out_, kf.t);
  put(out_, kf.session);
  putPose(out_, kf.T_odom_b);
  put(out_, static_cast<uint32_t>(kf.features.size()));
  for (const KeyframeLandmark& f : kf.features) {
    put(out_, static_cast<uint64_t>(f.id));
    putVec(out_, f.p_odom);
    put(out_, f.pixel.x());
    put(out_, f.pixel.y());
    put(out_, f.normalized.x());
    put(out_, f.normalized.y());
  }
  std::vector<uint8_t> png;
  if (!kf.image.empty()) cv::imencode(".png", kf.image, png);  // lossless: descriptors replay exactly
  put(out_, static_cast<uint32_t>(png.size()));
  if (!png.empty()) out_.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  put(out_, static_cast<uint8_t>((kf.port_depth ? kHasPortDepth : 0) | (kf.T_b_c ? kHasCameraExtrinsic : 0)));
  if (kf.port_depth) put(out_, *kf.port_depth);
  if (kf.T_b_c) putPose(out_, *kf.T_b_c);
  check();
}

void InputRecorder::write(const SignatureWindow& w) {
  put(out_, kSignature);
  put(out_, w.t);
  put(out_, w.t_start);
  put(out_, w.t_end);
  put(out_, w.frequency_hz);
  putVec(out_, w.amplitude_enu);
  putVec(out_, w.geomagnetic_body);
  put(out_, w.snr);
  put(out_, static_cast<uint8_t>(w.valid ? 1 : 0));
  put(out_, static_cast<uint32_t>(w.flags));
  put(out_, static_cast<uint32_t>(w.coil));
  check();
}

void InputRecorder::write(double t, const Eigen::Vector3d& field_body) {
  put(out_, kGeomagnetic);
  put(out_, t);
  putVec(out_, field_body);
  check();
}

void InputRecorder::flush() {
  out_.flush();
  check();
}

InputReader::InputReader(const std::string& path) : path_(path), in_(path, std::ios::binary) {
  if (!in_) throw std::runtime_error("input recording " + path + ": cannot open");
  char magic[8];
  in_.read(magic, sizeof(magic));
  in_.read(reinterpret_cast<char*>(&version_), sizeof(version_));
  if (!in_ || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0)
    throw std::runtime_error("input recording " + path + ": not a pose-graph input recording");
  if (version_ < 1 || version_ > kVersion)
    throw std::runtime_error("input recording " + path + ": version " + std::to_string(version_) + ", expected 1 to " +
                             std::to_string(kVersion));
}

bool InputReader::next(RecordedInput* input) {
  uint8_t kind = 0;
  in_.read(reinterpret_cast<char*>(&kind), 1);
  if (in_.eof()) return false;
  if (!in_) throw std::runtime_error("input recording " + path_ + ": read error");
  if (kind == kKeyframe) {
    KeyframeData kf;
    get(in_, &kf.t, path_);
    get(in_, &kf.session, path_);
    kf.T_odom_b = getPose(in_, path_);
    uint32_t n = 0;
    get(in_, &n, path_);
    if (n > kMaxLandmarks) throw std::runtime_error("input recording " + path_ + ": corrupt landmark count");
    kf.features.resize(n);
    for (KeyframeLandmark& f : kf.features) {
      uint64_t id = 0;
      get(in_, &id, path_);
      f.id = id;
      f.p_odom = getVec(in_, path_);
      get(in_, &f.pixel.x(), path_);
      get(in_, &f.pixel.y(), path_);
      get(in_, &f.normalized.x(), path_);
      get(in_, &f.normalized.y(), path_);
    }
    uint32_t bytes = 0;
    get(in_, &bytes, path_);
    if (bytes > kMaxImageBytes) throw std::runtime_error("input recording " + path_ + ": corrupt image size");
    if (bytes > 0) {
      std::vector<uint8_t> png(bytes);
      in_.read(reinterpret_cast<char*>(png.data()), bytes);
      if (!in_) throw std::runtime_error("input recording " + path_ + ": truncated image");
      kf.image = cv::imdecode(png, cv::IMREAD_UNCHANGED);
      if (kf.image.empty()) throw std::runtime_error("input recording " + path_ + ": undecodable image");
    }
    if (version_ >= 3) {
      uint8_t parts = 0;
      get(in_, &parts, path_);
      if (parts & kHasPortDepth) {
        double depth = 0.0;
        get(in_, &depth, path_);
        kf.port_depth = depth;
      }
      if (parts & kHasCameraExtrinsic) kf.T_b_c = getPose(in_, path_);
    }
    *input = std::move(kf);
    return true;
  }
  if (kind == kSignature) {
    SignatureWindow w;
    get(in_, &w.t, path_);
    get(in_, &w.t_start, path_);
    get(in_, &w.t_end, path_);
    get(in_, &w.frequency_hz, path_);
    w.amplitude_enu = getVec(in_, path_);
    w.geomagnetic_body = getVec(in_, path_);
    get(in_, &w.snr, path_);
    uint8_t valid = 0;
    get(in_, &valid, path_);
    w.valid = valid != 0;
    uint32_t flags = 0;
    get(in_, &flags, path_);
    w.flags = flags;
    if (version_ >= 2) {
      uint32_t coil = 0;
      get(in_, &coil, path_);
      if (coil > static_cast<uint32_t>(kMaxCoilIndex))
        throw std::runtime_error("input recording " + path_ + ": coil index " + std::to_string(coil) + " out of range");
      w.coil = static_cast<int>(coil);
    }
    *input = w;
    return true;
  }
  if (kind == kGeomagnetic) {
    RecordedGeomagnetic g;
    get(in_, &g.t, path_);
    g.field_body = getVec(in_, path_);
    *input = g;
    return true;
  }
  throw std::runtime_error("input recording " + path_ + ": unknown event kind " + std::to_string(kind));
}

}  // namespace vims
