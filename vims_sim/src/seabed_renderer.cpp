#include "vims_sim/seabed_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "vims_common/camera_model.h"

namespace vims {
namespace sim {
namespace {

constexpr int kResponseLutSize = 16384;
constexpr float kRangeTableStep = 0.005f;  // [m]; the range terms are smooth, linear interpolation suffices

/// Rec.709 opto-electronic transfer function (the usual camera response), linear in [0, 1].
double rec709(double linear) {
  linear = std::min(1.0, std::max(0.0, linear));
  return linear < 0.018 ? 4.5 * linear : 1.099 * std::pow(linear, 0.45) - 0.099;
}

/// Continuous mip level of a footprint ratio x = footprint / texel: floor(log2 x) plus the
/// position within the octave, linear in x (mantissa - 1), as GPUs blend mip levels; 0 below 1.
inline float mipLevel(float x) {
  if (!(x > 1.0f)) return 0.0f;
  uint32_t bits;
  std::memcpy(&bits, &x, sizeof(bits));
  const int exponent = static_cast<int>((bits >> 23) & 0xFF) - 127;
  bits = (bits & 0x007FFFFFu) | 0x3F800000u;  // mantissa in [1, 2)
  float mantissa;
  std::memcpy(&mantissa, &bits, sizeof(mantissa));
  return static_cast<float>(exponent) + (mantissa - 1.0f);
}

constexpr int kMaxLevels = 16;

}  // namespace

struct SeabedRenderer::SeenRegion {
  float min_x = std::numeric_limits<float>::max(), max_x = -std::numeric_limits<float>::max();
  float min_y = std::numeric_limits<float>::max(), max_y = -std::numeric_limits<float>::max();
  uint8_t finer_level_used[kMaxLevels] = {0};

  void add(float x, float y, float lambda) {
    finer_level_used[static_cast<int>(lambda)] = 1;
    min_x = std::min(min_x, x);
    max_x = std::max(max_x, x);
    min_y = std::min(min_y, y);
    max_y = std::max(max_y, y);
  }
};

SeabedRenderer::SeabedRenderer(const CameraCalibration& calibration, std::shared_ptr<const SeabedTexture> texture,
                               UnderwaterOptics optics, std::shared_ptr<const SeabedTerrain> terrain)
    : calib_(calibration),
      texture_(std::move(texture)),
      optics_(optics),
      terrain_(terrain && !terrain->isFlat() ? std::move(terrain) : nullptr) {
  if (!texture_) throw std::invalid_argument("SeabedRenderer: no texture");
  if (calib_.width <= 1 || calib_.height <= 1) throw std::invalid_argument("SeabedRenderer: bad image size");
  const CameraModel camera(calib_);
  // Every pixel's viewing ray (z = 1). A lens whose inverse fails inside the image cannot be
  // rendered: say so instead of drawing garbage.
  auto rayOf = [&camera](double u, double v) {
    const std::optional<Eigen::Vector3d> ray = camera.unprojectPixel(Eigen::Vector2d(u, v));
    if (!ray) {
      throw std::invalid_argument("SeabedRenderer: the camera model cannot unproject pixel (" + std::to_string(u) +
                                  ", " + std::to_string(v) + "): distortion too strong for the image size");
    }
    return *ray;
  };
  const int width = calib_.width, height = calib_.height;
  const size_t n = static_cast<size_t>(width) * height;
  // Undistort every pixel's ray once, including a one-pixel border for the pixel angles.
  std::vector<Eigen::Vector3d> unit((width + 1) * static_cast<size_t>(height + 1));
  for (int v = 0; v <= height; ++v)
    for (int u = 0; u <= width; ++u) unit[static_cast<size_t>(v) * (width + 1) + u] = rayOf(u, v).normalized();
  rays_c_.resize(n);
  ray_norm_.resize(n);
  pixel_angle_.resize(n);
  lamp_vignette_.resize(n);
  const double beam_angle = optics_.lamp_beam_half_angle_deg * M_PI / 180.0;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const size_t i = static_cast<size_t>(v) * width + u;
      const Eigen::Vector3d ray = rayOf(u, v);
      rays_c_[i] = ray.cast<float>();
      ray_norm_[i] = static_cast<float>(ray.norm());
      const Eigen::Vector3d& here = unit[static_cast<size_t>(v) * (width + 1) + u];
      const double right = std::acos(std::min(1.0, here.dot(unit[static_cast<size_t>(v) * (width + 1) + u + 1])));
      const double down = std::acos(std::min(1.0, here.dot(unit[static_cast<size_t>(v + 1) * (width + 1) + u])));
      pixel_angle_[i] = static_cast<float>(std::max(right, down));
      const double cos_off_axis = 1.0 / ray.norm();
      const double off_axis = std::acos(cos_off_axis);
      const double beam = std::exp(-(off_axis / beam_angle) * (off_axis / beam_angle));
      lamp_vignette_[i] = static_cast<float>(beam * std::pow(cos_off_axis, optics_.vignetting_exponent));
    }
  }
  // Lamp gain from the exposure's reference: white seabed, on axis, at reference_range in water of
  // reference_attenuation -> reference_signal; the lamp's power scales it (and the haze, which is
  // the lamp's light scattered back).
  const double r_ref = optics_.reference_range;
  const double lamp_gain = optics_.lamp_power * optics_.reference_signal * r_ref * r_ref *
                           std::exp(2.0 * optics_.reference_attenuation * r_ref);
  const double haze_level = optics_.lamp_power * optics_.backscatter;
  const int table_size = static_cast<int>(std::ceil(optics_.max_range / kRangeTableStep)) + 2;
  range_irradiance_.resize(table_size);
  range_haze_.resize(table_size);
  for (int k = 0; k < table_size; ++k) {
    const double r = std::max(1e-3, k * static_cast<double>(kRangeTableStep));
    range_irradiance_[k] = static_cast<float>(lamp_gain * std::exp(-2.0 * optics_.attenuation * r) / (r * r));
    range_haze_[k] = static_cast<float>(haze_level * (1.0 - std::exp(-r / optics_.backscatter_range)));
  }
  response_lut_.resize(kResponseLutSize);
  for (int i = 0; i < kResponseLutSize; ++i) {
    response_lut_[i] =
        static_cast<uint8_t>(std::lround(255.0 * rec709(static_cast<double>(i) / (kResponseLutSize - 1))));
  }
}

void SeabedRenderer::traceRays(const Eigen::Isometry3d& T_w_c, Workspace& ws, SeenRegion* seen) const {
  const size_t n = static_cast<size_t>(calib_.width) * calib_.height;
  if (texture_->levels() > kMaxLevels) throw std::invalid_argument("SeabedRenderer: at most 16 mip levels");
  ws.ground_x.resize(n);
  ws.ground_y.resize(n);
  ws.range.resize(n);
  ws.cos_incidence.resize(n);
  ws.level.resize(n);
  ws.hit.resize(n);
  if (terrain_) {
    traceTerrain(T_w_c, ws, seen);
  } else {
    tracePlane(T_w_c, ws, seen);
  }
}

// Ray-plane intersection with the seabed z = 0 (ground point relative to the camera), and the
// mip level from the pixel footprint there: the pixel's angle times the range, stretched by
// 1/cos(incidence) along the slant. Also which levels are used and the seen region.
void SeabedRenderer::tracePlane(const Eigen::Isometry3d& T_w_c, Workspace& ws, SeenRegion* seen) const {
  const size_t n = static_cast<size_t>(calib_.width) * calib_.height;
  const Eigen::Matrix3f R_w_c = T_w_c.linear().cast<float>();
  const float altitude = static_cast<float>(T_w_c.translation().z());
  const float inverse_texel0 = static_cast<float>(1.0 / texture_->texelSize(0));
  const float max_range = static_cast<float>(optics_.max_range);
  const float top_level = static_cast<float>(texture_->levels() - 1);
  float* ground_x = ws.ground_x.data();
  float* ground_y = ws.ground_y.data();
  float* range = ws.range.data();
  float* cos_incidence = ws.cos_incidence.data();
  float* level = ws.level.data();
  uint8_t* hit = ws.hit.data();
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f d = R_w_c * rays_c_[i];
    hit[i] = 0;
    if (altitude <= 0.0f || d.z() > -1e-6f) continue;
    const float t = -altitude / d.z();
    const float r = t * ray_norm_[i];
    if (r > max_range) continue;
    const float cos_inc = -d.z() / ray_norm_[i];
    const float x = t * d.x(), y = t * d.y();
    hit[i] = 1;
    ground_x[i] = x;
    ground_y[i] = y;
    range[i] = r;
    cos_incidence[i] = cos_inc;
    const float footprint = r * pixel_angle_[i] / cos_inc;
    const float lambda = std::min(top_level, mipLevel(footprint * inverse_texel0));
    level[i] = lambda;
    seen->add(x, y, lambda);
  }
}

// Ray tracing of the terrain: per pixel the first crossing of the ray with h(x, y), started
// from the row's previous hits (extrapolated), so most pixels take one height evaluation. The incidence is taken on
// the true surface normal, for the footprint (mip level) and for the Lambertian shading.
void SeabedRenderer::traceTerrain(const Eigen::Isometry3d& T_w_c, Workspace& ws, SeenRegion* seen) const {
  const int width = calib_.width, height = calib_.height;
  const SeabedTerrain& terrain = *terrain_;
  const Eigen::Matrix3d R_w_c = T_w_c.linear();
  const Eigen::Vector3d origin = T_w_c.translation();
  const float inverse_texel0 = static_cast<float>(1.0 / texture_->texelSize(0));
  const double max_range = optics_.max_range;
  const float top_level = static_cast<float>(texture_->levels() - 1);
  constexpr float kMinCosIncidence = 1e-3f;  // grazing hits: a finite footprint, (almost) no light
  double row_guess = -1.0;
  TerrainCursor cursor;  // neighbouring pixels see the same few rocks
  for (int v = 0; v < height; ++v) {
    double t1 = -1.0, t2 = -1.0, t3 = -1.0;  // hits of the three pixels to the left (-1: none)
    for (int u = 0; u < width; ++u) {
      const size_t i = static_cast<size_t>(v) * width + u;
      ws.hit[i] = 0;
      const Eigen::Vector3d d = R_w_c * rays_c_[i].cast<double>();
      // Quadratic extrapolation along the row: within ~1e-5 m on smooth ground, so one Newton
      // step usually ends the search.
      const double guess = t1 < 0.0   ? (u == 0 ? row_guess : -1.0)
                           : t2 < 0.0 ? t1
                           : t3 < 0.0 ? 2.0 * t1 - t2
                                      : 3.0 * (t1 - t2) + t3;
      TerrainHit crossing;
      if (!terrain.intersectRay(origin, d, max_range / ray_norm_[i], &crossing, guess, &cursor)) {
        t1 = t2 = t3 = -1.0;
        continue;
      }
      t3 = t2;
      t2 = t1;
      t1 = crossing.t;
      if (u == 0) row_guess = crossing.t;
      const double gx = crossing.gradient.x(), gy = crossing.gradient.y();
      // cos(incidence) = -ray . n with n = (-gx, -gy, 1) / |.| (float: it only scales light and footprint)
      const float cos_inc =
          std::max(kMinCosIncidence, static_cast<float>(-(d.z() - gx * d.x() - gy * d.y())) /
                                         (ray_norm_[i] * std::sqrt(static_cast<float>(1.0 + gx * gx + gy * gy))));
      const float x = static_cast<float>(crossing.t * d.x()), y = static_cast<float>(crossing.t * d.y());
      const float r = static_cast<float>(crossing.t * ray_norm_[i]);
      ws.hit[i] = 1;
      ws.ground_x[i] = x;
      ws.ground_y[i] = y;
      ws.range[i] = r;
      ws.cos_incidence[i] = cos_inc;
      const float footprint = r * pixel_angle_[i] / cos_inc;
      const float lambda = std::min(top_level, mipLevel(footprint * inverse_texel0));
      ws.level[i] = lambda;
      seen->add(x, y, lambda);
    }
  }
}

SeabedRenderer::ViewGeometry SeabedRenderer::viewGeometry(const Eigen::Isometry3d& T_w_c) const {
  Workspace ws;
  SeenRegion seen;
  traceRays(T_w_c, ws, &seen);
  ViewGeometry g;
  const int width = calib_.width, height = calib_.height;
  g.hit = cv::Mat(height, width, CV_8UC1, ws.hit.data()).clone();
  g.range = cv::Mat(height, width, CV_32FC1, ws.range.data()).clone();
  g.cos_incidence = cv::Mat(height, width, CV_32FC1, ws.cos_incidence.data()).clone();
  g.ground_x = cv::Mat(height, width, CV_32FC1, ws.ground_x.data()).clone();
  g.ground_y = cv::Mat(height, width, CV_32FC1, ws.ground_y.data()).clone();
  return g;
}

void SeabedRenderer::computeSignal(const Eigen::Isometry3d& T_w_c, Workspace& ws) const {
  const int width = calib_.width, height = calib_.height;
  const size_t n = static_cast<size_t>(width) * height;
  const Eigen::Vector3d p_w_c = T_w_c.translation();
  const int levels = texture_->levels();
  ws.maps.resize(levels);
  ws.sampled.resize(levels);

  // 1. Where every pixel's ray meets the seabed, its mip level, the levels used and the seen region.
  SeenRegion seen;
  traceRays(T_w_c, ws, &seen);
  float* ground_x = ws.ground_x.data();
  float* ground_y = ws.ground_y.data();
  float* range = ws.range.data();
  float* cos_incidence = ws.cos_incidence.data();
  float* level = ws.level.data();
  uint8_t* hit = ws.hit.data();
  const uint8_t* finer_level_used = seen.finer_level_used;
  const float seen_min_x = seen.min_x, seen_max_x = seen.max_x, seen_min_y = seen.min_y, seen_max_y = seen.max_y;
  // Level l is read by the pixels whose finer level is l or l - 1. Its patch covers the whole
  // seen region; only if that is unreasonably large (a far, grazing view) it is narrowed to the
  // pixels that actually read the level.
  constexpr int64_t kMaxPatchTexels = 2048 * 2048;
  std::vector<float> min_x(levels), max_x(levels), min_y(levels), max_y(levels);
  std::vector<uint8_t> level_used(levels, 0);
  for (int l = 0; l < levels; ++l) {
    level_used[l] = finer_level_used[l] || (l > 0 && finer_level_used[l - 1]);
    if (!level_used[l]) continue;
    min_x[l] = seen_min_x;
    max_x[l] = seen_max_x;
    min_y[l] = seen_min_y;
    max_y[l] = seen_max_y;
    const double s = texture_->texelSize(l);
    const double texels = ((seen_max_x - seen_min_x) / s + 6.0) * ((seen_max_y - seen_min_y) / s + 6.0);
    if (texels <= static_cast<double>(kMaxPatchTexels)) continue;
    min_x[l] = min_y[l] = std::numeric_limits<float>::max();
    max_x[l] = max_y[l] = -std::numeric_limits<float>::max();
    for (size_t i = 0; i < n; ++i) {
      if (!hit[i]) continue;
      const int l0 = static_cast<int>(level[i]);
      if (l0 != l && l0 + 1 != l) continue;
      min_x[l] = std::min(min_x[l], ground_x[i]);
      max_x[l] = std::max(max_x[l], ground_x[i]);
      min_y[l] = std::min(min_y[l], ground_y[i]);
      max_y[l] = std::max(max_y[l], ground_y[i]);
    }
  }

  // 2. Per used level: copy the covered seabed region out of the tile cache and sample it
  // bilinearly at every pixel's ground point (cv::remap). Map entries of pixels that do not
  // use a level are left as they are: their samples are never read.
  float origin_x[kMaxLevels], origin_y[kMaxLevels], inverse_texel[kMaxLevels];
  cv::Vec2f* map[kMaxLevels];
  std::vector<cv::Mat> patches(levels);
  int64_t gx0[kMaxLevels], gy0[kMaxLevels];
  size_t frame_tiles = 0;  // the largest level's region spans (about) the union of all
  for (int l = 0; l < levels; ++l) {
    if (!level_used[l]) continue;
    const double s = texture_->texelSize(l);
    gx0[l] = static_cast<int64_t>(std::floor((p_w_c.x() + min_x[l]) / s)) - 2;
    gy0[l] = static_cast<int64_t>(std::floor((p_w_c.y() + min_y[l]) / s)) - 2;
    const auto gx1 = static_cast<int64_t>(std::floor((p_w_c.x() + max_x[l]) / s)) + 3;
    const auto gy1 = static_cast<int64_t>(std::floor((p_w_c.y() + max_y[l]) / s)) + 3;
    patches[l].create(static_cast<int>(gy1 - gy0[l]), static_cast<int>(gx1 - gx0[l]), CV_8UC1);
    frame_tiles = std::max(frame_tiles, texture_->tilesSpanned(l, gx0[l], gy0[l], patches[l].cols, patches[l].rows));
  }
  texture_->reserveTiles(2 * frame_tiles);
  for (int l = 0; l < levels; ++l) {
    map[l] = nullptr;
    if (!level_used[l]) continue;
    const double s = texture_->texelSize(l);
    texture_->fillPatch(l, gx0[l], gy0[l], patches[l]);
    // Patch texel coordinates of a ground point: (p + x) / s - g0 - 0.5 (texel centres).
    origin_x[l] = static_cast<float>(p_w_c.x() / s - static_cast<double>(gx0[l]) - 0.5);
    origin_y[l] = static_cast<float>(p_w_c.y() / s - static_cast<double>(gy0[l]) - 0.5);
    inverse_texel[l] = static_cast<float>(1.0 / s);
    if (ws.maps[l].rows != height || ws.maps[l].cols != width || ws.maps[l].type() != CV_32FC2) {
      ws.maps[l] = cv::Mat(height, width, CV_32FC2, cv::Scalar(0, 0));
    }
    map[l] = ws.maps[l].ptr<cv::Vec2f>();
  }
  for (size_t i = 0; i < n; ++i) {
    if (!hit[i]) continue;
    const int l0 = static_cast<int>(level[i]);
    const int l1 = std::min(l0 + 1, levels - 1);
    map[l0][i] =
        cv::Vec2f(origin_x[l0] + ground_x[i] * inverse_texel[l0], origin_y[l0] + ground_y[i] * inverse_texel[l0]);
    map[l1][i] =
        cv::Vec2f(origin_x[l1] + ground_x[i] * inverse_texel[l1], origin_y[l1] + ground_y[i] * inverse_texel[l1]);
  }
  const uint8_t* sampled[kMaxLevels];
  for (int l = 0; l < levels; ++l) {
    sampled[l] = nullptr;
    if (patches[l].empty()) continue;
    cv::remap(patches[l], ws.sampled[l], ws.maps[l], cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    sampled[l] = ws.sampled[l].ptr<uint8_t>();
  }

  // 3. Photometry: lamp light on a Lambertian seabed plus backscatter haze, vignetted.
  ws.signal.create(height, width, CV_32FC1);
  float* out = ws.signal.ptr<float>();
  const float saturated_haze = static_cast<float>(optics_.lamp_power * optics_.backscatter);
  const float* irradiance_table = range_irradiance_.data();
  const float* haze_table = range_haze_.data();
  const int last_entry = static_cast<int>(range_irradiance_.size()) - 2;
  const float inverse_step = 1.0f / kRangeTableStep;
  for (size_t i = 0; i < n; ++i) {
    if (!hit[i]) {
      out[i] = lamp_vignette_[i] * saturated_haze;
      continue;
    }
    const float lambda = level[i];
    const int l0 = static_cast<int>(lambda);
    const int l1 = std::min(l0 + 1, levels - 1);
    const float f = lambda - static_cast<float>(l0);
    const float a0 = sampled[l0][i];
    const float a1 = sampled[l1][i];
    const float albedo = (a0 + (a1 - a0) * f) * (1.0f / 255.0f);
    // Range terms, linearly interpolated in their tables.
    const float x = range[i] * inverse_step;
    const int k = std::min(static_cast<int>(x), last_entry);
    const float w = x - static_cast<float>(k);
    const float irradiance = irradiance_table[k] + w * (irradiance_table[k + 1] - irradiance_table[k]);
    const float haze = haze_table[k] + w * (haze_table[k + 1] - haze_table[k]);
    out[i] = lamp_vignette_[i] * (albedo * irradiance * cos_incidence[i] + haze);
  }
}

cv::Mat SeabedRenderer::renderSignal(const Eigen::Isometry3d& T_w_c) const {
  Workspace ws;
  computeSignal(T_w_c, ws);
  return ws.signal;
}

cv::Mat SeabedRenderer::render(const Eigen::Isometry3d& T_w_c, uint64_t noise_seed, bool lamp_on) const {
  Workspace ws;
  return render(T_w_c, noise_seed, lamp_on, ws);
}

cv::Mat SeabedRenderer::render(const Eigen::Isometry3d& T_w_c, uint64_t noise_seed, bool lamp_on, Workspace& ws) const {
  const int width = calib_.width, height = calib_.height;
  if (lamp_on) {
    computeSignal(T_w_c, ws);
    cv::GaussianBlur(ws.signal, ws.blurred, cv::Size(5, 5), optics_.blur_sigma_px, optics_.blur_sigma_px,
                     cv::BORDER_REFLECT);
  } else {
    ws.blurred.create(height, width, CV_32FC1);
    ws.blurred.setTo(0.0f);
  }
  ws.noise.create(height, width, CV_32FC1);
  cv::RNG rng(noise_seed | 1u);  // cv::RNG treats 0 specially
  rng.fill(ws.noise, cv::RNG::NORMAL, 0.0, 1.0);

  // Sensor: shot noise (Poisson, Gaussian approximation) and read noise in electrons, then the
  // response curve to 8 bits.
  cv::Mat image(height, width, CV_8UC1);
  const float full_well = static_cast<float>(optics_.full_well_electrons);
  const float read2 = static_cast<float>(optics_.read_noise_electrons * optics_.read_noise_electrons);
  const float lut_scale = (kResponseLutSize - 1) / full_well;
  const float lut_max = static_cast<float>(kResponseLutSize - 1);
  const size_t n = static_cast<size_t>(width) * height;
  const float* s = ws.blurred.ptr<float>();
  const float* z = ws.noise.ptr<float>();
  uint8_t* out = image.ptr<uint8_t>();
  for (size_t i = 0; i < n; ++i) {
    const float electrons = std::max(0.0f, s[i]) * full_well;
    const float noisy = electrons + std::sqrt(electrons + read2) * z[i];
    const float index = std::min(lut_max, std::max(0.0f, noisy * lut_scale));
    out[i] = response_lut_[static_cast<size_t>(index + 0.5f)];
  }
  return image;
}

}  // namespace sim
}  // namespace vims
