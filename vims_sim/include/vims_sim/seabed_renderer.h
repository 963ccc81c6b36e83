#pragma once
/// @file seabed_renderer.h
/// @brief Renders what the downward camera sees of the textured seabed, underwater.
///
/// Per pixel: the undistorted viewing ray (precomputed once) is intersected with the seabed:
/// the plane z = 0, or the terrain's surface h(x, y) (ray-traced, rocks and occlusion
/// included); the albedo is looked up in the seabed texture at the hit's (x, y) with trilinear
/// mip filtering (level from the pixel's footprint on the surface, so no aliasing shimmer); the
/// lamp's light (co-located with the camera, Gaussian beam) reaches the seabed with 1/r^2
/// spreading and attenuation exp(-c r) both ways, the surface is Lambertian (true normal);
/// backscatter haze from the lit
/// water column grows with range; the lens adds cos^n vignetting and a mild Gaussian blur; the
/// sensor adds shot and read noise; a Rec.709 response curve maps to 8 bits.
/// With the lamp off (lamp failure) only the sensor noise remains.

#include <Eigen/Geometry>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "vims_common/sequence_config.h"
#include "vims_sim/seabed_texture.h"
#include "vims_sim/terrain.h"

namespace vims {
namespace sim {

struct UnderwaterOptics {
  double attenuation = 0.06;             ///< [1/m] beam attenuation of the water (clear tank/coastal)
  double backscatter = 0.04;             ///< saturated backscatter radiance (same scale as the image signal)
  double backscatter_range = 2.5;        ///< [m] range scale over which the backscatter builds up
  double lamp_beam_half_angle_deg = 65;  ///< angle at which the lamp intensity falls to 1/e
  double vignetting_exponent = 2.0;      ///< lens vignetting cos^n of the off-axis angle (a wide-angle
                                         ///< lens behind a dome port vignettes less than cos^4)
  double reference_range = 2.0;          ///< [m] range at which ...
  double reference_signal = 1.3;         ///< ... a white seabed on the optical axis gives this linear signal
                                         ///< (1 = full well: exposure set so sand, albedo ~0.5, is well exposed at 2 m)
  double reference_attenuation = 0.06;   ///< [1/m] ... in water of this attenuation (the exposure's set-up)
  double lamp_power = 1.0;               ///< the lamp's light (and its haze) relative to the reference
  double blur_sigma_px = 0.7;            ///< optical blur [pixels]
  double full_well_electrons = 8000.0;   ///< shot noise: signal 1.0 = this many electrons
  double read_noise_electrons = 6.0;     ///< read noise [e-]
  double max_range = 40.0;               ///< [m] rays hitting the seabed further away see only haze
};

class SeabedRenderer {
 public:
  /// Scratch buffers of one rendering thread (a frame needs ~20 MB of them; reusing them
  /// avoids allocating and page-faulting that much memory for every frame).
  class Workspace {
   public:
    Workspace() = default;

   private:
    friend class SeabedRenderer;
    std::vector<float> ground_x, ground_y, range, cos_incidence, level;  ///< ground point relative to the camera
    std::vector<uint8_t> hit;
    std::vector<cv::Mat> maps, sampled;
    cv::Mat signal, blurred, noise;
  };

  /// `terrain`: the seabed's shape; null or flat: the plane z = 0.
  SeabedRenderer(const CameraCalibration& calibration, std::shared_ptr<const SeabedTexture> texture,
                 UnderwaterOptics optics = UnderwaterOptics(), std::shared_ptr<const SeabedTerrain> terrain = nullptr);

  /// Renders the mono8 image seen from camera pose T_w_c (camera optical frame in world).
  /// `noise_seed` fixes the sensor noise (same seed, same pose: identical image).
  /// lamp_on = false renders a lamp failure: a black frame with only the sensor noise.
  /// Thread-safe (const); give each thread its own workspace.
  cv::Mat render(const Eigen::Isometry3d& T_w_c, uint64_t noise_seed, bool lamp_on, Workspace& workspace) const;
  cv::Mat render(const Eigen::Isometry3d& T_w_c, uint64_t noise_seed, bool lamp_on = true) const;

  /// The noise-free linear signal (CV_32FC1, before blur, noise and the response curve), for
  /// tests and for calibrating the photometry.
  cv::Mat renderSignal(const Eigen::Isometry3d& T_w_c) const;

  /// Where each pixel's ray meets the seabed (for tests): `hit` CV_8UC1 (1: the ray meets the
  /// seabed within max_range), and CV_32FC1 range [m], cos_incidence (of the ray on the surface
  /// normal) and the hit's x and y relative to the camera [m].
  struct ViewGeometry {
    cv::Mat hit, range, cos_incidence, ground_x, ground_y;
  };
  ViewGeometry viewGeometry(const Eigen::Isometry3d& T_w_c) const;

  const UnderwaterOptics& optics() const { return optics_; }

 private:
  /// What step 1 of a frame (the ray casting) tells the texture sampling.
  struct SeenRegion;
  void computeSignal(const Eigen::Isometry3d& T_w_c, Workspace& ws) const;
  void traceRays(const Eigen::Isometry3d& T_w_c, Workspace& ws, SeenRegion* seen) const;
  void tracePlane(const Eigen::Isometry3d& T_w_c, Workspace& ws, SeenRegion* seen) const;
  void traceTerrain(const Eigen::Isometry3d& T_w_c, Workspace& ws, SeenRegion* seen) const;

  CameraCalibration calib_;
  std::shared_ptr<const SeabedTexture> texture_;
  UnderwaterOptics optics_;
  std::shared_ptr<const SeabedTerrain> terrain_;  ///< null: the flat seabed z = 0
  std::vector<Eigen::Vector3f> rays_c_;           ///< per pixel, undistorted, z = 1
  std::vector<float> ray_norm_;                   ///< |ray|
  std::vector<float> pixel_angle_;                ///< angle subtended by the pixel (larger of its two sides) [rad]
  std::vector<float> lamp_vignette_;              ///< lamp beam * cos^n vignetting per pixel
  /// Over range, kRangeTableStep apart: lamp light reaching the camera from the seabed per unit
  /// albedo and cos(incidence) (1/r^2 spreading, attenuation both ways), and backscatter haze.
  std::vector<float> range_irradiance_;
  std::vector<float> range_haze_;
  std::vector<uint8_t> response_lut_;  ///< linear signal -> 8-bit (Rec.709 OETF)
};

}  // namespace sim
}  // namespace vims
