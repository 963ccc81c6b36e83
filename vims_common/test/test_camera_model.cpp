#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <random>
#include <stdexcept>

#include "vims_common/camera_model.h"

namespace {

// A wide-angle underwater-housing-like lens (EuRoC-like magnitudes): barrel distortion strong
// enough that the image corners exercise the inverse distortion.
vims::CameraCalibration distortedCalibration() {
  vims::CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = 458.654;
  c.fy = 457.296;
  c.cx = 317.305;
  c.cy = 248.164;
  c.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  return c;
}

std::vector<Eigen::Vector2d> pixelsOverImage(const vims::CameraModel& camera, double step) {
  std::vector<Eigen::Vector2d> pixels;
  for (double v = 0.0; v <= camera.height() - 1; v += step)
    for (double u = 0.0; u <= camera.width() - 1; u += step) pixels.emplace_back(u, v);
  // The four extreme corners (pixel edges), where the distortion is strongest.
  const double w = camera.width() - 0.5, h = camera.height() - 0.5;
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(-0.5, -0.5), Eigen::Vector2d(w, -0.5), Eigen::Vector2d(-0.5, h), Eigen::Vector2d(w, h)}) {
    pixels.push_back(corner);
  }
  return pixels;
}

}  // namespace

TEST(CameraModel, PixelUndistortRedistortRoundTripBelowHundredthPixelIncludingCorners) {
  const vims::CameraModel camera(distortedCalibration());
  double worst = 0.0;
  for (const Eigen::Vector2d& pixel : pixelsOverImage(camera, 8.0)) {
    const std::optional<Eigen::Vector2d> normalized = camera.normalizedFromPixel(pixel);
    ASSERT_TRUE(normalized.has_value()) << "pixel " << pixel.transpose();
    worst = std::max(worst, (camera.pixelFromNormalized(*normalized) - pixel).norm());
  }
  EXPECT_LT(worst, 0.01);
  EXPECT_LT(worst, 1e-6) << "Newton inverse should reach (near) machine precision";
}

TEST(CameraModel, UndistortInvertsDistortOnNormalisedPlane) {
  const vims::CameraModel camera(distortedCalibration());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-0.75, 0.75), uy(-0.6, 0.6);  // beyond the image corners
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector2d m(ux(rng), uy(rng));
    const std::optional<Eigen::Vector2d> back = camera.undistortNormalized(camera.distortNormalized(m));
    ASSERT_TRUE(back.has_value()) << m.transpose();
    EXPECT_LT((*back - m).norm(), 1e-10) << m.transpose();
  }
}

TEST(CameraModel, UnprojectProjectRoundTripAtRandomDepths) {
  const vims::CameraModel camera(distortedCalibration());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> depth(0.3, 20.0);
  for (const Eigen::Vector2d& pixel : pixelsOverImage(camera, 16.0)) {
    const std::optional<Eigen::Vector3d> ray = camera.unprojectPixel(pixel);
    ASSERT_TRUE(ray.has_value());
    EXPECT_DOUBLE_EQ(ray->z(), 1.0);
    const std::optional<Eigen::Vector2d> projected = camera.project(depth(rng) * *ray);
    ASSERT_TRUE(projected.has_value());
    EXPECT_LT((*projected - pixel).norm(), 1e-6) << pixel.transpose();
  }
}

TEST(CameraModel, ProjectWithoutDistortionIsPinhole) {
  vims::CameraCalibration calibration = distortedCalibration();
  calibration.distortion = {0, 0, 0, 0};
  const vims::CameraModel camera(calibration);
  const Eigen::Vector3d p(0.4, -0.25, 2.0);
  const Eigen::Vector2d expected(calibration.fx * 0.2 + calibration.cx, calibration.fy * -0.125 + calibration.cy);
  EXPECT_LT((*camera.project(p) - expected).norm(), 1e-12);
}

TEST(CameraModel, ProjectionJacobianMatchesCentralDifferences) {
  const vims::CameraModel camera(distortedCalibration());
  const double h = 1e-6;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.1, -0.2, 1.5), Eigen::Vector3d(-1.2, 0.8, 2.0),
                                   Eigen::Vector3d(0.0, 0.0, 0.5), Eigen::Vector3d(2.5, 1.9, 4.0)}) {
    Eigen::Matrix<double, 2, 3> analytic;
    ASSERT_TRUE(camera.project(p, &analytic).has_value());
    Eigen::Matrix<double, 2, 3> numeric;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d dp = Eigen::Vector3d::Zero();
      dp[k] = h;
      numeric.col(k) = (*camera.project(p + dp) - *camera.project(p - dp)) / (2 * h);
    }
    EXPECT_LT((analytic - numeric).norm(), 1e-4 * std::max(1.0, numeric.norm())) << "at " << p.transpose();
  }
}

TEST(CameraModel, DistortionJacobianMatchesCentralDifferences) {
  const vims::CameraModel camera(distortedCalibration());
  const double h = 1e-7;
  for (const Eigen::Vector2d& m : {Eigen::Vector2d(0.3, -0.4), Eigen::Vector2d(-0.6, 0.5), Eigen::Vector2d(0, 0)}) {
    Eigen::Matrix2d analytic;
    camera.distortNormalized(m, &analytic);
    Eigen::Matrix2d numeric;
    for (int k = 0; k < 2; ++k) {
      Eigen::Vector2d dm = Eigen::Vector2d::Zero();
      dm[k] = h;
      numeric.col(k) = (camera.distortNormalized(m + dm) - camera.distortNormalized(m - dm)) / (2 * h);
    }
    EXPECT_LT((analytic - numeric).norm(), 1e-6) << "at " << m.transpose();
  }
}

TEST(CameraModel, RefusesPointsBehindCameraAndNonFiniteInput) {
  const vims::CameraModel camera(distortedCalibration());
  EXPECT_FALSE(camera.project(Eigen::Vector3d(0.1, 0.1, -1.0)).has_value());
  EXPECT_FALSE(camera.project(Eigen::Vector3d(0.1, 0.1, 0.0)).has_value());
  EXPECT_FALSE(camera.project(Eigen::Vector3d(std::nan(""), 0.1, 1.0)).has_value());
  EXPECT_FALSE(camera.normalizedFromPixel(Eigen::Vector2d(std::nan(""), 3.0)).has_value());
}

TEST(CameraModel, RefusesWhereTheDistortionFoldsOver) {
  // Strong barrel distortion rd = r (1 - 0.4 r^2) peaks at rd = 0.609 (r = 0.913) and turns back:
  // a distorted radius beyond the peak has no preimage; the model must say so instead of
  // returning a point on the wrong branch.
  vims::CameraCalibration calibration = distortedCalibration();
  calibration.distortion = {-0.4, 0.0, 0.0, 0.0};
  const vims::CameraModel camera(calibration);
  EXPECT_FALSE(camera.undistortNormalized(Eigen::Vector2d(0.7, 0.0)).has_value());
  EXPECT_FALSE(camera.undistortNormalized(Eigen::Vector2d(0.5, 0.5)).has_value());
  const std::optional<Eigen::Vector2d> inside = camera.undistortNormalized(Eigen::Vector2d(0.5, 0.0));
  ASSERT_TRUE(inside.has_value());
  EXPECT_LT(inside->norm(), 0.913);  // the branch before the peak
}

TEST(CameraModel, RejectsUnusableCalibration) {
  vims::CameraCalibration bad_focal = distortedCalibration();
  bad_focal.fx = 0.0;
  EXPECT_THROW(vims::CameraModel{bad_focal}, std::invalid_argument);
  vims::CameraCalibration bad_model = distortedCalibration();
  bad_model.model = "fisheye";
  EXPECT_THROW(vims::CameraModel{bad_model}, std::invalid_argument);
  vims::CameraCalibration bad_size = distortedCalibration();
  bad_size.width = 0;
  EXPECT_THROW(vims::CameraModel{bad_size}, std::invalid_argument);
}

TEST(CameraModel, IsInImageHonoursBorder) {
  const vims::CameraModel camera(distortedCalibration());
  EXPECT_TRUE(camera.isInImage(Eigen::Vector2d(0, 0)));
  EXPECT_FALSE(camera.isInImage(Eigen::Vector2d(0, 0), 5.0));
  EXPECT_TRUE(camera.isInImage(Eigen::Vector2d(634, 474), 5.0));
  EXPECT_FALSE(camera.isInImage(Eigen::Vector2d(640, 10)));
}

namespace {

// A fisheye behind a dome port (the simulator's equidistant rig): 110 deg across 640 px.
vims::CameraCalibration fisheyeCalibration() {
  vims::CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = 291.5;
  c.fy = 291.2;
  c.cx = 319.1;
  c.cy = 241.2;
  c.distortion_model = vims::DistortionModel::kEquidistant;
  c.distortion = {-0.0268, 0.00664, -0.00072, 0.00077};
  return c;
}

}  // namespace

// The equidistant model is OpenCV's fisheye model (the contract's definition): same pixels.
TEST(CameraModelEquidistant, MatchesOpenCvFisheye) {
  const vims::CameraCalibration calibration = fisheyeCalibration();
  const vims::CameraModel camera(calibration);
  const cv::Matx33d K(calibration.fx, 0, calibration.cx, 0, calibration.fy, calibration.cy, 0, 0, 1);
  const cv::Vec4d D(calibration.distortion[0], calibration.distortion[1], calibration.distortion[2],
                    calibration.distortion[3]);
  std::vector<cv::Point3d> points;
  for (double x = -2.0; x <= 2.0; x += 0.25)
    for (double y = -1.5; y <= 1.5; y += 0.25) points.emplace_back(x, y, 1.0);
  std::vector<cv::Point2d> expected;
  cv::fisheye::projectPoints(points, expected, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const std::optional<Eigen::Vector2d> pixel = camera.project(Eigen::Vector3d(points[i].x, points[i].y, points[i].z));
    ASSERT_TRUE(pixel.has_value());
    EXPECT_LT((*pixel - Eigen::Vector2d(expected[i].x, expected[i].y)).norm(), 1e-6) << points[i];
  }
}

TEST(CameraModelEquidistant, RoundTripOverTheWholeImageAndJacobians) {
  const vims::CameraModel camera(fisheyeCalibration());
  double worst = 0.0;
  for (const Eigen::Vector2d& pixel : pixelsOverImage(camera, 8.0)) {
    const std::optional<Eigen::Vector3d> ray = camera.unprojectPixel(pixel);
    ASSERT_TRUE(ray.has_value()) << "pixel " << pixel.transpose();
    worst = std::max(worst, (*camera.project(1.7 * *ray) - pixel).norm());
  }
  EXPECT_LT(worst, 1e-6);
  const double h = 1e-7;
  for (const Eigen::Vector2d& m :
       {Eigen::Vector2d(0.3, -0.4), Eigen::Vector2d(-1.6, 0.9), Eigen::Vector2d(1e-9, 0), Eigen::Vector2d(0, 0)}) {
    Eigen::Matrix2d analytic;
    camera.distortNormalized(m, &analytic);
    Eigen::Matrix2d numeric;
    for (int k = 0; k < 2; ++k) {
      Eigen::Vector2d dm = Eigen::Vector2d::Zero();
      dm[k] = h;
      numeric.col(k) = (camera.distortNormalized(m + dm) - camera.distortNormalized(m - dm)) / (2 * h);
    }
    EXPECT_LT((analytic - numeric).norm(), 1e-6) << "at " << m.transpose();
  }
}
