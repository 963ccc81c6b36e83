// The reprojection residual's pixel-noise whitening through the lens (ReprojectionOptions::
// lens_weighting, pixelFromNormalizedJacobian): which lenses it applies to, its Jacobian against
// the camera model's projection, and what it means for a fisheye's edge feature.
#include <gtest/gtest.h>

#include <cmath>

#include "vims_estimator/factor_options.h"
#include "vims_estimator/factors/reprojection_factor.h"

namespace vims {
namespace {

CameraCalibration radtanCamera() {
  CameraCalibration c;
  c.fx = 421.0;
  c.fy = 419.5;
  c.cx = 321.0;
  c.cy = 238.0;
  c.distortion = {-0.25, 0.06, 3e-4, -2e-4};  // a flat port's strong barrel distortion
  return c;
}

CameraCalibration fisheyeCamera() {
  CameraCalibration c = radtanCamera();
  c.fx = 290.0;
  c.fy = 289.4;
  c.distortion_model = DistortionModel::kEquidistant;
  c.distortion = {-0.02, 0.005, -0.001, 0.0005};
  return c;
}

TEST(LensWeighting, AutoWeighsAFisheyeThroughItsLensAndARadtanLensByItsFocalLengths) {
  EXPECT_TRUE(weighsThroughLens(LensWeighting::kAuto, DistortionModel::kEquidistant));
  EXPECT_FALSE(weighsThroughLens(LensWeighting::kAuto, DistortionModel::kRadtan));
  EXPECT_TRUE(weighsThroughLens(LensWeighting::kOn, DistortionModel::kRadtan));
  EXPECT_FALSE(weighsThroughLens(LensWeighting::kOff, DistortionModel::kEquidistant));

  const CameraModel camera(radtanCamera());
  const Eigen::Matrix2d focal = pixelFromNormalizedJacobian(camera, Eigen::Vector2d(0.6, -0.4), false);
  EXPECT_EQ(focal, Eigen::Matrix2d(Eigen::Vector2d(421.0, 419.5).asDiagonal()));
}

TEST(LensWeighting, JacobianIsTheProjectionsDerivative) {
  for (const CameraCalibration& calibration : {radtanCamera(), fisheyeCamera()}) {
    const CameraModel camera(calibration);
    // On axis, half way out, and 63 deg off axis (the fisheye's image edge).
    const double edge = std::tan(63.0 * M_PI / 180.0) * std::sqrt(0.5);
    for (const Eigen::Vector2d& uv :
         {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.5, -0.3), Eigen::Vector2d(edge, edge)}) {
      const Eigen::Matrix2d W = pixelFromNormalizedJacobian(camera, uv, true);
      const double h = 1e-6;
      for (int k = 0; k < 2; ++k) {
        const Eigen::Vector2d e = h * Eigen::Vector2d::Unit(k);
        const Eigen::Vector2d numeric =
            (camera.pixelFromNormalized(uv + e) - camera.pixelFromNormalized(uv - e)) / (2 * h);
        EXPECT_LT((W.col(k) - numeric).norm(), 1e-5 * numeric.norm()) << uv.transpose() << " column " << k;
      }
    }
  }
}

TEST(LensWeighting, APixelErrorAtTheFisheyesEdgeWhitensToItsSigmaOnlyThroughTheLens) {
  const CameraModel camera(fisheyeCamera());
  const double sigma_px = 1.5;
  const Eigen::Vector2d uv = Eigen::Vector2d(std::tan(63.0 * M_PI / 180.0), 0.0);  // 63 deg off axis
  const Eigen::Vector2d pixel = camera.pixelFromNormalized(uv);
  for (const Eigen::Vector2d& error_px : {Eigen::Vector2d(sigma_px, 0.0), Eigen::Vector2d(0.0, sigma_px)}) {
    const auto moved = camera.normalizedFromPixel(pixel + error_px);
    ASSERT_TRUE(moved.has_value());
    const Eigen::Vector2d r = *moved - uv;
    // One sigma in the image is one sigma in the whitened residual through the lens ...
    EXPECT_NEAR((pixelFromNormalizedJacobian(camera, uv, true) * r / sigma_px).norm(), 1.0, 0.02);
    // ... and about 1.8x (across: tan(theta) / theta_d) to 5x (radially: 1/cos^2(theta)) with the
    // focal scaling.
    const double focal_sigmas = (pixelFromNormalizedJacobian(camera, uv, false) * r / sigma_px).norm();
    EXPECT_GT(focal_sigmas, 1.3);
  }
  const auto radial = camera.normalizedFromPixel(pixel + Eigen::Vector2d(sigma_px, 0.0));
  EXPECT_GT((pixelFromNormalizedJacobian(camera, uv, false) * (*radial - uv) / sigma_px).norm(), 3.5);
}

TEST(LensWeighting, OptionRoundTripsAndABadValueNamesTheKey) {
  FactorOptions changed;
  changed.reprojection.lens_weighting = LensWeighting::kOn;
  const FactorOptions back = FactorOptions::fromReader(ConfigReader::fromString(changed.toYaml()));
  EXPECT_EQ(back.reprojection.lens_weighting, LensWeighting::kOn);
  EXPECT_EQ(FactorOptions::fromReader(ConfigReader::fromString("{}")).reprojection.lens_weighting,
            LensWeighting::kAuto);
  try {
    FactorOptions::fromReader(ConfigReader::fromString("reprojection: {lens_weighting: fisheye}"));
    FAIL() << "unknown weighting accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("reprojection.lens_weighting"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace vims
